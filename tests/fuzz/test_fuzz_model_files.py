"""Fuzzed model folders and mapping files: a result, or one of our errors, never a crash or a hang (issue 42).

A **model folder** starts as a small fitted ``capstan-simple`` or ``passage-capstan`` model; each
example changes ``model.json`` (a value anywhere replaced by another JSON value, a key dropped or
added) and/or ``arrays.npz`` (cut short, bytes flipped, arrays replaced by others of any dtype
and shape), with the digest and the record of the arrays resealed or not. The folder is loaded
and the model predicts; the command line evaluates it. A **mapping file** starts as a bench's
valid mapping; each example changes a value, drops or adds a key, and the file is read through
it by the library and by ``tendon-id info``.

Every outcome must be a result (a model and its predictions; a recording) or a
:class:`~tendon_id.errors.TendonIdError`, and the command line must agree with the library:
exit 0 where the library gave a result with finite numbers, exit 2 where it raised or where its
predictions are not finite (the command line never reports a NaN metric). The CI part runs a few
dozen examples of each; ``test_fuzz_model_files_10000`` and ``test_fuzz_mappings_10000`` (slow)
run ``$TENDON_ID_FUZZ_EXAMPLES`` (default 10 000) each and print their tally.
"""

from __future__ import annotations

import hashlib
import io
import json
import math
import os
import shutil
import sys
import tempfile
import time
from collections import Counter
from contextlib import redirect_stderr, redirect_stdout
from datetime import timedelta
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from hostile_cases import MAPPING, bench_csv  # noqa: E402

from tendon_id import zoo  # noqa: E402
from tendon_id.checks import non_finite_paths  # noqa: E402
from tendon_id.cli import main  # noqa: E402
from tendon_id.data.mapping import load_mapping, read_files  # noqa: E402
from tendon_id.errors import TendonIdError  # noqa: E402
from tendon_id.zoo.arrays_file import members_record  # noqa: E402

CI_EXAMPLES = 40
FUZZ = dict(
    derandomize=True,
    deadline=timedelta(seconds=30),
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large, HealthCheck.function_scoped_fixture],
    print_blob=True,
)
TALLY: Counter = Counter()

# ---- JSON and TOML values a user (or an attacker) could write ----------------------------------
scalars = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(min_value=-(10**40), max_value=10**40),
    st.sampled_from([0, -1, 2**63, 10**30]),
    st.floats(allow_nan=True, allow_infinity=True),
    st.sampled_from([1e308, -1e308, 5e-324, 1e-300, 1e300]),
    st.text(max_size=20),
    st.sampled_from(
        ["capstan-simple", "passage-capstan", "tied", "per-guide", "cpu", "cuda", "stick_slip", "", "x" * 500]
    ),
)
values = st.recursive(
    scalars,
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=8), inner, max_size=4),
    max_leaves=10,
)


def _paths(doc, prefix=()):
    """Every path to a value in a JSON document."""
    yield prefix
    if isinstance(doc, dict):
        for k, v in doc.items():
            yield from _paths(v, (*prefix, k))
    elif isinstance(doc, list):
        for i, v in enumerate(doc):
            yield from _paths(v, (*prefix, i))


def _set(doc, path, value):
    if not path:
        return value
    target = doc
    for key in path[:-1]:
        target = target[key]
    target[path[-1]] = value
    return doc


def _drop(doc, path):
    if path:
        target = doc
        for key in path[:-1]:
            target = target[key]
        del target[path[-1]]
    return doc


@st.composite
def json_edits(draw, doc, root=True):
    """``doc`` with one to three edits: a value replaced, a key dropped or added (``root``: the document too)."""
    doc = json.loads(json.dumps(doc))
    for _ in range(draw(st.integers(1, 3))):
        paths = [p for p in _paths(doc) if root or p]
        if not paths:
            break
        path = draw(st.sampled_from(paths))
        action = draw(st.sampled_from(["replace", "drop", "add"]))
        if action == "replace":
            doc = _set(doc, path, draw(values))
        elif action == "drop" and path:
            doc = _drop(doc, path)
        elif action == "add" and isinstance(_get(doc, path), dict):
            _get(doc, path)[draw(st.text(max_size=8))] = draw(values)
    return doc


def _get(doc, path):
    for key in path:
        doc = doc[key]
    return doc


# ---- model folders --------------------------------------------------------------------------
@pytest.fixture(scope="module")
def saved(tmp_path_factory):
    root = tmp_path_factory.mktemp("fuzz-models")
    assert (
        main(["simulate", "--protocol", "posterior-3", "--frames", "120", "--seed", "3", "--out", str(root / "p.csv")])
        == 0
    )
    assert main(["fit", "capstan-simple", "--data", str(root / "p.csv"), "--out", str(root / "cap")]) == 0
    bench_csv(root / "b.csv", n=1500)  # the passage fit skips its first second (warmup_s)
    (root / "b.toml").write_text(MAPPING)
    assert (
        main(
            [
                "fit",
                "passage-capstan",
                "--mapping",
                str(root / "b.toml"),
                "--data",
                str(root / "b.csv"),
                "--out",
                str(root / "pas"),
            ]
        )
        == 0
    )
    return root


arrays_edits = st.one_of(
    st.tuples(st.just("cut"), st.floats(0, 1)),
    st.tuples(st.just("flip"), st.floats(0, 1), st.integers(1, 255)),
    st.tuples(
        st.just("replace"),
        st.sampled_from(["<f8", "<f4", "<i8", "|u1", "|b1", "<c16", "<U3", "|O"]),
        st.lists(st.integers(0, 4), max_size=3),
        st.sampled_from([0.0, 1.0, -1.0, 0.3, 1e300, float("nan"), float("inf")]),
    ),
)


def _edit_arrays(folder: Path, edit) -> None:
    path = folder / "arrays.npz"
    blob = bytearray(path.read_bytes())
    if edit[0] == "cut":
        path.write_bytes(bytes(blob[: int(edit[1] * len(blob))]))
    elif edit[0] == "flip" and blob:
        i = min(int(edit[1] * len(blob)), len(blob) - 1)
        blob[i] ^= edit[2]
        path.write_bytes(bytes(blob))
    elif edit[0] == "replace":
        _, dtype, shape, fill = edit
        with np.load(path) as npz:
            names = list(npz.files)
        if dtype == "|O":
            a = np.empty(shape, dtype=object)
        else:
            with np.errstate(all="ignore"):
                a = np.full(shape, fill).astype(dtype) if dtype not in ("<U3",) else np.full(shape, "abc")
        np.savez(path, **{n: a for n in names})


def _reseal(folder: Path, members: bool) -> None:
    doc_path = folder / "model.json"
    try:
        doc = json.loads(doc_path.read_text())
        blob = (folder / "arrays.npz").read_bytes()
        doc["arrays"].update(sha256=hashlib.sha256(blob).hexdigest(), bytes=len(blob))
        if members:
            with np.load(folder / "arrays.npz", allow_pickle=True) as npz:
                doc["arrays"]["members"] = members_record({k: npz[k] for k in npz.files})
        doc_path.write_text(json.dumps(doc))
    except Exception:  # noqa: BLE001 - a document the edits broke stays broken
        pass


def _quiet(fn):
    with redirect_stdout(io.StringIO()), redirect_stderr(io.StringIO()) as err:
        out = fn()
    return out, err.getvalue()


def run_model_example(saved: Path, which: str, doc_edit, arrays_edit, reseal: str) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp) / "m"
        shutil.copytree(saved / which, folder)
        if doc_edit is not None:
            (folder / "model.json").write_text(json.dumps(doc_edit, allow_nan=True))
        if arrays_edit is not None:
            _edit_arrays(folder, arrays_edit)
        if reseal != "no":
            _reseal(folder, members=reseal == "members")
        data = (
            ["--data", str(saved / "p.csv")]
            if which == "cap"
            else ["--mapping", str(saved / "b.toml"), "--data", str(saved / "b.csv")]
        )
        t0 = time.perf_counter()
        try:
            model = zoo.load(folder)
            if which == "cap":
                from tendon_id.data import Recording

                rec = Recording.read(saved / "p.csv")
            else:
                rec = read_files([saved / "b.csv"], load_mapping(saved / "b.toml"))[0]
            pred, score = _quiet(lambda: (model.predict(rec), model.score(rec)))[0]
            # what the command line reports: the metrics, R^2 undefined for a constant reference
            finite = np.all(np.isfinite(pred)) and not non_finite_paths(score, undefined=("r2",))
            library = "result" if finite else "non-finite"
        except TendonIdError:
            library = "error"
        code, err = _quiet(lambda: main(["evaluate", "--model", str(folder), *data]))
        assert time.perf_counter() - t0 < 60, "an example took a minute: a hang"
        assert code in (0, 2), f"exit {code}: {err}"
        assert "Traceback" not in err and "internal error" not in err, err
        assert (code == 0) == (library == "result"), f"library {library}, CLI exit {code}: {err}"
        TALLY[f"{which}:{library}"] += 1


def model_examples():
    doc_of = {}

    @st.composite
    def example(draw):
        which = draw(st.sampled_from(["cap", "pas"]))
        doc = doc_of[which]
        doc_edit = draw(st.none() | json_edits(doc))
        arrays_edit = draw(st.none() | arrays_edits)
        reseal = draw(st.sampled_from(["no", "digest", "members"]))
        return which, doc_edit, arrays_edit, reseal

    return doc_of, example()


def _docs(saved: Path) -> dict:
    return {w: json.loads((saved / w / "model.json").read_text()) for w in ("cap", "pas")}


def test_model_folders_are_a_result_or_a_documented_error(saved):
    doc_of, strategy = model_examples()
    doc_of.update(_docs(saved))

    @settings(max_examples=CI_EXAMPLES, **FUZZ)
    @given(strategy)
    def run(example):
        run_model_example(saved, *example)

    run()


@pytest.mark.slow
def test_fuzz_model_files_10000(saved):
    doc_of, strategy = model_examples()
    doc_of.update(_docs(saved))
    TALLY.clear()

    @settings(max_examples=int(os.environ.get("TENDON_ID_FUZZ_EXAMPLES", "10000")), **FUZZ)
    @given(strategy)
    def run(example):
        run_model_example(saved, *example)

    run()
    print(json.dumps({"model folders": dict(TALLY)}, indent=2))


# ---- mapping files ----------------------------------------------------------------------------
def _toml_value(v) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        return "nan" if math.isnan(v) else ("inf" if v > 0 else "-inf") if math.isinf(v) else repr(v)
    if isinstance(v, str):
        return json.dumps(v)  # a TOML basic string takes JSON's escapes
    if isinstance(v, list):
        return "[" + ", ".join(_toml_value(x) for x in v if x is not None) + "]"
    if isinstance(v, dict):
        return "{" + ", ".join(f"{json.dumps(k)} = {_toml_value(x)}" for k, x in v.items() if x is not None) + "}"
    return '""'  # TOML has no null


def toml_text(doc: dict) -> str:
    top = [f"{json.dumps(k)} = {_toml_value(v)}" for k, v in doc.items() if not isinstance(v, dict) and v is not None]
    tables = [
        f"[{json.dumps(k)}]\n" + "\n".join(f"{json.dumps(a)} = {_toml_value(b)}" for a, b in v.items() if b is not None)
        for k, v in doc.items()
        if isinstance(v, dict)
    ]
    return "\n".join(top) + "\n" + "\n".join(tables) + "\n"


def _mapping_doc() -> dict:
    import tomllib

    return tomllib.loads(MAPPING)


@pytest.fixture(scope="module")
def bench(tmp_path_factory):
    root = tmp_path_factory.mktemp("fuzz-mappings")
    bench_csv(root / "b.csv", n=300)
    return root


def run_mapping_example(bench: Path, doc: dict) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "m.toml"
        path.write_text(toml_text(doc))
        t0 = time.perf_counter()
        try:
            _quiet(lambda: read_files([bench / "b.csv"], load_mapping(path)))
            library = "result"
        except TendonIdError:
            library = "error"
        code, err = _quiet(lambda: main(["info", "--mapping", str(path), str(bench / "b.csv")]))
        assert time.perf_counter() - t0 < 60, "an example took a minute: a hang"
        assert code in (0, 2), f"exit {code}: {err}"
        assert "Traceback" not in err and "internal error" not in err, err
        assert (code == 0) == (library == "result"), f"library {library}, CLI exit {code}: {err}"
        TALLY[f"mapping:{library}"] += 1


def test_mapping_files_are_a_result_or_a_documented_error(bench):
    @settings(max_examples=CI_EXAMPLES, **FUZZ)
    @given(json_edits(_mapping_doc(), root=False))
    def run(doc):
        run_mapping_example(bench, doc)

    run()


@pytest.mark.slow
def test_fuzz_mappings_10000(bench):
    TALLY.clear()

    @settings(max_examples=int(os.environ.get("TENDON_ID_FUZZ_EXAMPLES", "10000")), **FUZZ)
    @given(json_edits(_mapping_doc(), root=False))
    def run(doc):
        run_mapping_example(bench, doc)

    run()
    print(json.dumps({"mapping files": dict(TALLY)}, indent=2))
