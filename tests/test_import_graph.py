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
