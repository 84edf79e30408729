"""The import graph of the three packages.

No cycle, layered tendon_id -> learners -> friction_models, no private names.
"""

import importlib.util
import textwrap
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
spec = importlib.util.spec_from_file_location("import_graph", ROOT / ".ci" / "import_graph.py")
import_graph = importlib.util.module_from_spec(spec)
spec.loader.exec_module(import_graph)


def test_the_project_has_no_cycle_no_upward_import_and_no_private_import(capsys):
    code = import_graph.main([str(ROOT)])
    assert code == 0, capsys.readouterr().out


def _tree(tmp_path, files: dict[str, str]) -> Path:
    for pkg in import_graph.PACKAGES:
        (tmp_path / pkg).mkdir()
        (tmp_path / pkg / "__init__.py").write_text("")
    for name, text in files.items():
        (tmp_path / name).write_text(textwrap.dedent(text))
    return tmp_path


def test_the_checker_finds_a_cycle_hidden_in_a_function(tmp_path, capsys):
    root = _tree(
        tmp_path,
        {"tendon_id/a.py": "from tendon_id.b import f\n", "tendon_id/b.py": "def f():\n    from tendon_id import a\n"},
    )
    assert import_graph.main([str(root)]) == 1
    assert "cycle: tendon_id.a <-> tendon_id.b" in capsys.readouterr().out


def test_the_checker_finds_an_upward_import_and_a_private_name(tmp_path, capsys):
    root = _tree(
        tmp_path,
        {
            "friction_models/law.py": "from learners.net import _helper\n",
            "learners/net.py": "def _helper():\n    pass\n",
        },
    )
    assert import_graph.main([str(root)]) == 1
    out = capsys.readouterr().out
    assert "layering: friction_models.law imports learners.net" in out
    assert "imports private _helper from learners.net" in out


def test_the_checker_finds_generic_code_that_imports_a_family_module(tmp_path, capsys):
    root = _tree(
        tmp_path,
        {
            "tendon_id/diagnosis.py": "from tendon_id.capstan import CapstanModel\n",
            "tendon_id/capstan.py": "from tendon_id.errors import ConfigError\n",
            "tendon_id/errors.py": "class ConfigError(Exception):\n    pass\n",
        },
    )
    assert import_graph.main([str(root)]) == 1
    out = capsys.readouterr().out
    assert "seam: generic tendon_id.diagnosis imports tendon_id.capstan" in out
    (root / "tendon_id/diagnosis.py").write_text("from tendon_id.errors import ConfigError\n")
    assert import_graph.main([str(root)]) == 0  # the foundation is allowed


def test_the_checker_finds_foundation_that_reaches_a_family_and_a_family_listed_as_generic(tmp_path, capsys):
    root = _tree(
        tmp_path,
        {
            "tendon_id/errors.py": "from tendon_id.capstan import X\n",
            "tendon_id/capstan.py": "X = 1\n",
        },
    )
    (root / "tendon_id/family").mkdir()
    (root / "tendon_id/family/__init__.py").write_text("")
    (root / "tendon_id/family/registry.py").write_text('BUILTIN = {"snake": "tendon_id.errors:SNAKE"}\n')
    assert import_graph.main([str(root)]) == 1
    out = capsys.readouterr().out
    assert "seam: foundation tendon_id.errors imports tendon_id.capstan" in out
    assert "seam: the family module tendon_id.errors is listed as generic or foundation" in out
