"""Defect generators for the input fuzz (issue 19, item 1).

A :class:`Doc` is what will be written to disk: a DataFrame as a foreign program might hold it
(any dtypes, duplicate column names), the metadata (or None, or not even a dict), the format,
and byte-level edits applied after writing (a UTF-8 BOM, ``;`` separators, truncation).

Each defect is a ``(kind, params)`` tuple drawn by :func:`defect_specs` and applied by
:func:`apply`. Parameters that pick a column or a row are fractions in [0, 1), mapped onto
whatever the frame holds when the defect is applied, so defects combine in any order and
hypothesis can shrink them.
"""

from __future__ import annotations

import copy
import dataclasses
import json
import math
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from hypothesis import strategies as st

from tendon_id.data import Recording
from tendon_id.data.io import META_KEY
from tendon_id.data.schema import TENSION_RE, THETA_RE

FRAMES_PER_TRAJECTORY = 12


@lru_cache(maxsize=None)
def _base(n_modules: int) -> tuple[pd.DataFrame, dict]:
    from tendon_id.datasets import load_recipe
    from tendon_id.sim import simulate

    recipe = load_recipe("snake12-paper")
    if n_modules == 2:
        rec = simulate(recipe, "single-passage", frames=2 * FRAMES_PER_TRAJECTORY, seed=1).recording
    else:
        robot = dataclasses.replace(recipe.robot, n_modules=n_modules)
        recipe = dataclasses.replace(recipe, robot=robot)
        rec = simulate(recipe, "planned-paths", frames=2 * FRAMES_PER_TRAJECTORY, seed=1).recording
    frame = rec.frame.copy()
    # Two trajectories, time restarting in each: splits, contiguity and time checks all have work.
    k = FRAMES_PER_TRAJECTORY
    frame["trajectory"] = ["a"] * k + ["b"] * k
    frame["t"] = np.tile(np.arange(k) / rec.sample_rate_hz, 2)
    meta = rec.meta
    Recording(frame, meta)  # the base must be valid
    return frame, meta


def base_doc(n_modules: int, fmt: str) -> "Doc":
    """A valid small recording of ``n_modules`` modules (simulated, 2 x 12 frames) as a :class:`Doc`."""
    frame, meta = _base(n_modules)
    return Doc(frame.copy(), copy.deepcopy(meta), fmt)


@dataclass
class Doc:
    """A recording as it will be written: data, metadata, format and byte-level edits."""

    frame: pd.DataFrame
    meta: Any
    fmt: str  # "parquet" or "csv"
    bom: bool = False
    sep: str = ","
    truncate: float | None = None  # keep this fraction of the data file's bytes
    sidecar: bool = True  # CSV: write the metadata sidecar
    text_edits: list[str] = field(default_factory=list)  # CSV: edits of the text (see write)
    sidecar_edit: tuple | None = None  # CSV: replace or truncate the sidecar
    raw_meta: bytes | None = None  # Parquet: these bytes as our metadata

    def __repr__(self) -> str:
        cols = ", ".join(map(str, self.frame.columns))
        dtypes = sorted({str(d) for d in self.frame.dtypes})
        meta = self.meta if not isinstance(self.meta, dict) else {k: self.meta[k] for k in list(self.meta)[:8]}
        return (
            f"Doc({self.fmt}, {self.frame.shape[0]} rows, dtypes {dtypes}, bom={self.bom}, sep={self.sep!r}, "
            f"truncate={self.truncate}, sidecar={self.sidecar}, columns [{cols}], meta {meta})"
        )

    # ---- helpers for the defects -----------------------------------------------------------
    def columns(self, pred=None) -> list[int]:
        """Positions of the columns whose name satisfies ``pred``."""
        return [i for i, c in enumerate(self.frame.columns) if pred is None or pred(str(c))]

    def set_cell(self, col: int, row: int, value: Any) -> None:
        s = self.frame.iloc[:, col]
        if isinstance(value, str) or value is None or isinstance(value, (bool, list)):
            s = s.astype(object)
        elif s.dtype.kind not in "fc":
            s = s.astype(object)
        values = s.to_numpy(copy=True)
        values[row] = value
        self._replace(col, pd.Series(values, index=self.frame.index, dtype=s.dtype))

    def _replace(self, col: int, series: pd.Series) -> None:
        names = list(self.frame.columns)
        parts = [self.frame.iloc[:, i] for i in range(len(names))]
        parts[col] = series
        self.frame = pd.concat(parts, axis=1, ignore_index=True)
        self.frame.columns = names

    # ---- writing ----------------------------------------------------------------------------
    def write(self, folder: Path) -> Path:
        """Write the file (and a CSV's sidecar); return its path."""
        path = folder / f"rec.{self.fmt}"
        if self.fmt == "parquet":
            _write_parquet(self.frame, self.meta, path, self.raw_meta)
        else:
            text = self.frame.to_csv(index=False, sep=self.sep, lineterminator="\n")
            encoding = "utf-8-sig" if self.bom else "utf-8"
            for edit in self.text_edits:
                text, encoding = _edit_text(text, edit, encoding)
            path.write_bytes(text.encode(encoding, errors="replace"))
            side = path.with_suffix(".json")
            if self.sidecar and self.meta is not None:
                side.write_text(json.dumps(self.meta, default=_plain), encoding="utf-8")
            if self.sidecar_edit:
                how, arg = self.sidecar_edit
                if how == "truncate":
                    data = side.read_bytes() if side.exists() else b"{}"
                    side.write_bytes(data[: int(len(data) * arg)])
                elif how == "text":
                    side.write_text(arg, encoding="utf-8")
                else:
                    side.write_bytes(arg)
        if self.truncate is not None:
            data = path.read_bytes()
            path.write_bytes(data[: int(len(data) * self.truncate)])
        return path


def _edit_text(text: str, edit: str, encoding: str) -> tuple[str, str]:
    lines = text.split("\n")
    if edit == "crlf":
        return text.replace("\n", "\r\n"), encoding
    if edit == "trailing-comma":
        return "\n".join(line + "," if line else line for line in lines), encoding
    if edit == "blank-lines":
        return "\n\n" + "\n\n".join(lines), encoding
    if edit == "latin-1":
        # A trajectory id with a non-ASCII letter, in a legacy encoding.
        return text.replace("\na,", "\nmé,", 1), "latin-1"
    if edit == "utf-16":
        return text, "utf-16"
    if edit == "nul-bytes":
        return text.replace(",", ",\0", 3), encoding
    if edit == "long-header":
        # One header name longer than the csv module's field limit (131 072 characters).
        return "x" * 200_000 + "," + text, encoding
    if edit == "quote":
        return '"' + text, encoding
    if edit == "comment-line":
        return "# exported by a logger\n" + text, encoding
    if edit == "padded":
        return "\n".join(", ".join(f" {v} " for v in line.split(",")) if line else line for line in lines), encoding
    raise ValueError(edit)


def _plain(obj: Any) -> Any:
    if isinstance(obj, np.generic):
        return obj.item()
    return str(obj)


def _arrow_column(s: pd.Series):
    import pyarrow as pa

    try:
        return pa.array(s, from_pandas=True)
    except (pa.ArrowException, TypeError, ValueError, OverflowError):
        # Mixed Python objects: a foreign writer would store them as text.
        return pa.array([None if v is None else str(v) for v in s], type=pa.string())


def _write_parquet(frame: pd.DataFrame, meta: Any, path: Path, raw_meta: bytes | None = None) -> None:
    import pyarrow as pa
    import pyarrow.parquet as pq

    # from_arrays keeps duplicate column names, which a foreign writer may produce.
    arrays = [_arrow_column(frame.iloc[:, i]) for i in range(frame.shape[1])]
    table = pa.Table.from_arrays(arrays, names=[str(c) for c in frame.columns])
    md = None if meta is None else {META_KEY: json.dumps(meta, default=_plain).encode("utf-8")}
    if raw_meta is not None:
        md = {META_KEY: raw_meta}
    table = table.replace_schema_metadata(md)
    pq.write_table(table, path)


# ---- the defects -----------------------------------------------------------------------------


def _pick(items: list, u: float):
    return items[min(int(u * len(items)), len(items) - 1)] if items else None


def _is_numeric_col(c: str) -> bool:
    return c == "t" or bool(THETA_RE.match(c) or TENSION_RE.match(c))


def _is_tension(c: str) -> bool:
    return bool(TENSION_RE.match(c))


def _is_theta(c: str) -> bool:
    return bool(THETA_RE.match(c))


def _n_of(doc: Doc) -> int:
    ks = [int(m.group(1)) for c in doc.frame.columns if (m := THETA_RE.match(str(c)))]
    return max(ks) if ks else 2


def d_dtype(doc: Doc, variant: str, uc: float, ur: float) -> None:
    cols = doc.columns(_is_numeric_col) + doc.columns(lambda c: c == "trajectory")
    col = _pick(cols, uc)
    if col is None or len(doc.frame) == 0:
        return
    row = _pick(list(range(len(doc.frame))), ur)
    s = doc.frame.iloc[:, col]
    if variant == "text":
        doc.set_cell(col, row, "abc")
    elif variant == "numeric-text":
        # A number stored as text in an otherwise numeric column.
        v = s.iloc[row]
        doc.set_cell(col, row, f"{v}" if not isinstance(v, str) else v)
    elif variant == "empty-text":
        doc.set_cell(col, row, "")
    elif variant == "none":
        doc.set_cell(col, row, None)
    elif variant == "list":
        doc.set_cell(col, row, [1.0, 2.0])
    elif variant == "int":
        try:
            doc._replace(col, pd.to_numeric(s, errors="coerce").round().astype("Int64"))
        except (TypeError, ValueError, OverflowError):
            return
    elif variant == "bool":
        doc._replace(col, pd.Series(np.arange(len(s)) % 2 == 0, index=s.index))
    elif variant == "all-text":
        doc._replace(col, s.astype(str))
    elif variant == "complex":
        try:
            doc._replace(col, pd.to_numeric(s, errors="coerce").astype(complex))
        except (TypeError, ValueError):
            return
    elif variant == "datetime":
        try:
            doc._replace(col, pd.to_datetime(pd.to_numeric(s, errors="coerce"), unit="s"))
        except (TypeError, ValueError, OverflowError, pd.errors.OutOfBoundsDatetime):
            return
    elif variant == "timedelta":
        try:
            doc._replace(col, pd.to_timedelta(pd.to_numeric(s, errors="coerce"), unit="s"))
        except (TypeError, ValueError, OverflowError, pd.errors.OutOfBoundsTimedelta):
            return
    elif variant == "category":
        doc._replace(col, s.astype("category"))
    elif variant == "uint64-max":
        doc._replace(col, pd.Series(np.full(len(s), np.iinfo(np.uint64).max, dtype=np.uint64), index=s.index))
    elif variant == "int8":
        try:
            doc._replace(col, pd.to_numeric(s, errors="coerce").fillna(0).clip(-128, 127).astype(np.int8))
        except (TypeError, ValueError):
            return
    elif variant == "float32":
        try:
            doc._replace(col, pd.to_numeric(s, errors="coerce").astype(np.float32))
        except (TypeError, ValueError):
            return


def d_nonfinite(doc: Doc, value: float, uc: float, ur: float) -> None:
    col = _pick(doc.columns(_is_numeric_col), uc)
    if col is not None and len(doc.frame):
        doc.set_cell(col, _pick(list(range(len(doc.frame))), ur), value)


def d_rows(doc: Doc, variant: str, ur: float) -> None:
    f = doc.frame
    if variant == "empty":
        doc.frame = f.iloc[:0]
    elif variant == "one-frame":
        doc.frame = f.iloc[: min(1, len(f))]
    elif variant == "one-frame-trajectory" and len(f) > 1:
        # The last frame becomes a trajectory of its own.
        if "trajectory" in f.columns:
            col = list(f.columns).index("trajectory")
            doc.set_cell(col, len(f) - 1, "z")
    elif variant == "zero-bytes":
        doc.truncate = 0.0
    elif variant == "drop-row" and len(f):
        row = _pick(list(range(len(f))), ur)
        doc.frame = f.drop(index=f.index[row]).reset_index(drop=True)


def d_time(doc: Doc, variant: str, ur: float) -> None:
    f = doc.frame
    n = len(f)
    if n < 2:
        return
    row = max(1, _pick(list(range(n)), ur))
    if variant == "duplicate" and "t" in f.columns:
        col = list(f.columns).index("t")
        doc.set_cell(col, row, f.iloc[row - 1, col])
    elif variant == "swap-rows":
        order = list(range(n))
        order[row - 1], order[row] = order[row], order[row - 1]
        doc.frame = f.iloc[order].reset_index(drop=True)
    elif variant == "reverse":
        doc.frame = f.iloc[::-1].reset_index(drop=True)
    elif variant == "shuffle":
        rng = np.random.default_rng(int(ur * 1e6))
        doc.frame = f.iloc[rng.permutation(n)].reset_index(drop=True)
    elif variant == "constant" and "t" in f.columns:
        col = list(f.columns).index("t")
        doc._replace(col, pd.Series(np.zeros(n), index=f.index))


def d_missing_column(doc: Doc, uc: float) -> None:
    col = _pick(doc.columns(), uc)
    if col is not None:
        keep = [i for i in range(doc.frame.shape[1]) if i != col]
        doc.frame = doc.frame.iloc[:, keep]


EXTRA_NAMES = (
    "user_signal",
    "theta_01_x",
    "theta_0_x",
    "tension_act_1_4",
    "tension_joint_0_1",
    "Theta_1_x",
    "theta_1_z",
    "Unnamed: 0",
    "",
    "theta_99_x",
    "tension_act_7_1",
)


def d_extra_column(doc: Doc, name: str, variant: str) -> None:
    n = len(doc.frame)
    values = {
        "numbers": np.linspace(0.0, 1.0, n),
        "text": np.array(["x"] * n, dtype=object),
        "nan": np.full(n, np.nan),
    }[variant]
    doc.frame = doc.frame.assign(**{"__extra__": values}).rename(columns={"__extra__": name})


def d_duplicate_column(doc: Doc, uc: float, variant: str) -> None:
    col = _pick(doc.columns(), uc)
    if col is None:
        return
    s = doc.frame.iloc[:, col]
    if variant == "different" and s.dtype.kind == "f":
        s = s * 1.5
    name = doc.frame.columns[col]
    doc.frame = pd.concat([doc.frame, s.rename(name)], axis=1)


def d_degrees(doc: Doc, variant: str, uc: float) -> None:
    cols = doc.columns(_is_theta)
    if variant == "one":
        cols = [_pick(cols, uc)] if cols else []
    for col in cols:
        s = doc.frame.iloc[:, col]
        if s.dtype.kind == "f":
            doc._replace(col, s * (180.0 / math.pi))


def d_tension(doc: Doc, value: float, uc: float, ur: float) -> None:
    col = _pick(doc.columns(_is_tension), uc)
    if col is not None and len(doc.frame):
        if value == "column":
            s = doc.frame.iloc[:, col]
            if s.dtype.kind == "f":
                doc._replace(col, -s)
        else:
            doc.set_cell(col, _pick(list(range(len(doc.frame))), ur), value)


def d_huge(doc: Doc, value: float, uc: float, ur: float, whole: bool) -> None:
    col = _pick(doc.columns(_is_numeric_col), uc)
    if col is None or not len(doc.frame):
        return
    if whole:
        s = doc.frame.iloc[:, col]
        if s.dtype.kind == "f":
            doc._replace(col, s * value)
    else:
        doc.set_cell(col, _pick(list(range(len(doc.frame))), ur), value)


def d_mismatched_n(doc: Doc, variant: str) -> None:
    n = _n_of(doc)
    f = doc.frame
    if variant in ("meta+1", "meta-1", "meta0") and isinstance(doc.meta, dict):
        doc.meta["n_modules"] = {"meta+1": n + 1, "meta-1": n - 1, "meta0": 0}[variant]
    elif variant == "drop-last-module":
        doc.frame = f[
            [c for c in f.columns if not str(c).endswith(tuple(f"_{n}_{s}" for s in ("x", "y", "1", "2", "3")))]
        ]
    elif variant == "drop-module-1-angles":
        doc.frame = f[[c for c in f.columns if c not in ("theta_1_x", "theta_1_y")]]
    elif variant == "add-module":
        extra = {f"theta_{n + 1}_{a}": 0.01 for a in "xy"}
        extra.update({f"tension_act_{n + 1}_{i}": 100.0 for i in (1, 2, 3)})
        extra.update({f"tension_joint_{n + 1}_{i}": 90.0 for i in (1, 2, 3)})
        doc.frame = f.assign(**extra)
    elif variant == "robot":
        if isinstance(doc.meta, dict):
            robot = doc.meta.get("robot") if isinstance(doc.meta.get("robot"), dict) else {}
            doc.meta["robot"] = {**robot, "n_modules": n + 2}


META_VARIANTS = (
    "no-meta",
    "not-an-object",
    "sample-rate-contradicts",
    "sample-rate-zero",
    "sample-rate-text",
    "schema-newer",
    "schema-text",
    "n-modules-text",
    "n-modules-float",
    "n-modules-bool",
    "protocol-number",
    "effects-number",
    "seed-float",
    "robot-list",
    "robot-unknown-key",
    "robot-bad-value",
    "robot-null-value",
    "robot-huge-n",
    "robot-alpha-degrees",
    "kind-passage",
    "unknown-key",
    "no-sidecar",
    "nan-rate",
)


def d_meta(doc: Doc, variant: str) -> None:
    m = doc.meta if isinstance(doc.meta, dict) else {}
    robot = m.get("robot") if isinstance(m.get("robot"), dict) else {}
    if variant == "no-meta":
        doc.meta = None
        return
    if variant == "not-an-object":
        doc.meta = [1, 2, 3]
        return
    if variant == "no-sidecar":
        doc.sidecar = False
        return
    updates: dict[str, Any] = {
        "sample-rate-contradicts": {"sample_rate_hz": 1000.0},
        "sample-rate-zero": {"sample_rate_hz": 0},
        "sample-rate-text": {"sample_rate_hz": "10 Hz"},
        "nan-rate": {"sample_rate_hz": float("nan")},
        "schema-newer": {"schema_version": 99},
        "schema-text": {"schema_version": "1"},
        "n-modules-text": {"n_modules": "two"},
        "n-modules-float": {"n_modules": float(_n_of(doc))},
        "n-modules-bool": {"n_modules": True},
        "protocol-number": {"protocol": 3},
        "effects-number": {"effects": 7},
        "seed-float": {"seed": 1.5},
        "robot-list": {"robot": [1, 2]},
        "robot-unknown-key": {"robot": {**robot, "wheel_count": 4}},
        "robot-bad-value": {"robot": {**robot, "alpha_0": "wide"}},
        "robot-null-value": {"robot": {**robot, "link_length": None}},
        "robot-huge-n": {"robot": {**robot, "n_modules": 10**30}},
        "robot-alpha-degrees": {"robot": {**robot, "alpha_0": 3.0, "alpha_c": 5.0}},
        "kind-passage": {"kind": "passage"},
        "unknown-key": {"operator": "anna"},
    }[variant]
    doc.meta = {**m, **updates}


CSV_TEXT_EDITS = (
    "crlf",
    "trailing-comma",
    "blank-lines",
    "latin-1",
    "utf-16",
    "comment-line",
    "padded",
    "nul-bytes",
    "long-header",
    "quote",
)


EDGE_VARIANTS = (
    "zero-angles",
    "near-pi-angles",
    "constant-tensions",
    "tiny-tensions",
    "near-max-tensions",
    "terminal-above-actuator",
    "many-trajectories",
    "epoch-time",
    "irregular-time",
    "tiny-time-steps",
    "numeric-trajectory-ids",
)


def d_edge(doc: Doc, variant: str, u: float) -> None:
    """Valid but extreme data: it passes validation and stresses the fit and the metrics."""
    f = doc.frame
    n = len(f)

    def each(pred, fn):
        for col in doc.columns(pred):
            s = doc.frame.iloc[:, col]
            if s.dtype.kind == "f":
                doc._replace(col, fn(s))

    if variant == "zero-angles":
        each(_is_theta, lambda s: s * 0.0)
    elif variant == "near-pi-angles":
        each(_is_theta, lambda s: pd.Series(np.where(np.arange(n) % 2, 3.14159, -3.14159), index=s.index))
    elif variant == "constant-tensions":
        each(_is_tension, lambda s: s * 0.0 + 100.0)
    elif variant == "tiny-tensions":
        each(_is_tension, lambda s: s * 1e-300)
    elif variant == "near-max-tensions":
        each(_is_tension, lambda s: s * (9.9e5 / 250.0))
    elif variant == "terminal-above-actuator":
        each(lambda c: c.startswith("tension_joint_"), lambda s: s * 10.0)
    elif variant == "many-trajectories" and "trajectory" in f.columns:
        col = list(f.columns).index("trajectory")
        doc._replace(col, pd.Series([f"t{i // 2}" for i in range(n)], index=f.index))
        if "t" in f.columns:
            doc._replace(list(f.columns).index("t"), pd.Series((np.arange(n) % 2) * 0.1, index=f.index))
    elif variant == "epoch-time":
        each(lambda c: c == "t", lambda s: s + 1.7e9)
    elif variant == "irregular-time":
        each(lambda c: c == "t", lambda s: s * s.rank())  # steps that grow along each trajectory
    elif variant == "tiny-time-steps":
        each(lambda c: c == "t", lambda s: s * 1e-12)
    elif variant == "numeric-trajectory-ids" and "trajectory" in f.columns:
        col = list(f.columns).index("trajectory")
        ids = f.iloc[:, col].map({"a": 1, "b": 2})
        if ids.notna().all():
            doc._replace(col, ids.astype(np.int64))


def d_file(doc: Doc, variant: str, frac: float) -> None:
    if variant == "truncate":
        doc.truncate = frac
    elif variant == "bom":
        doc.fmt, doc.bom = "csv", True
    elif variant == "semicolon":
        doc.fmt, doc.sep = "csv", ";"
    elif variant == "tab":
        doc.fmt, doc.sep = "csv", "\t"
    elif variant in CSV_TEXT_EDITS:
        doc.fmt = "csv"
        doc.text_edits.append(variant)
    elif variant == "sidecar-truncated":
        doc.fmt, doc.sidecar_edit = "csv", ("truncate", frac)
    elif variant == "sidecar-nan":
        doc.fmt, doc.sidecar_edit = "csv", ("text", '{"n_modules": NaN, "sample_rate_hz": Infinity}')
    elif variant == "sidecar-empty":
        doc.fmt, doc.sidecar_edit = "csv", ("text", "")
    elif variant == "sidecar-latin-1":
        doc.fmt, doc.sidecar_edit = "csv", ("bytes", b'{"protocol": "caf\xe9"}')
    elif variant == "parquet-meta-garbage":
        doc.fmt, doc.raw_meta = "parquet", b"\xff\xfe not json"
    elif variant == "parquet-meta-deep":
        doc.fmt, doc.raw_meta = "parquet", ("[" * 100000 + "]" * 100000).encode()


# ---- strategies ------------------------------------------------------------------------------

U = st.floats(0.0, 1.0, exclude_max=True, allow_nan=False)

#: Every defect kind and the strategy of its parameters.
KINDS: dict[str, Any] = {
    "dtype": st.tuples(
        st.sampled_from(
            [
                "text",
                "numeric-text",
                "empty-text",
                "none",
                "list",
                "int",
                "bool",
                "all-text",
                "complex",
                "float32",
                "datetime",
                "timedelta",
                "category",
                "uint64-max",
                "int8",
            ]
        ),
        U,
        U,
    ),
    "nan-inf": st.tuples(st.sampled_from([math.nan, math.inf, -math.inf]), U, U),
    "rows": st.tuples(st.sampled_from(["empty", "one-frame", "one-frame-trajectory", "zero-bytes", "drop-row"]), U),
    "time": st.tuples(st.sampled_from(["duplicate", "swap-rows", "reverse", "shuffle", "constant"]), U),
    "missing-column": st.tuples(U),
    "extra-column": st.tuples(st.sampled_from(EXTRA_NAMES), st.sampled_from(["numbers", "text", "nan"])),
    "duplicate-column": st.tuples(U, st.sampled_from(["same", "different"])),
    "degrees": st.tuples(st.sampled_from(["all", "one"]), U),
    "tension": st.tuples(st.sampled_from([0.0, -0.0, -1.0, -1e-12, 5e-324, "column"]), U, U),
    "huge": st.tuples(
        st.sampled_from([1e300, -1e300, 1.7976931348623157e308, 1e30, 1e15, 1e-300, 3.0e38]), U, U, st.booleans()
    ),
    "mismatched-n": st.tuples(
        st.sampled_from(
            ["meta+1", "meta-1", "meta0", "drop-last-module", "drop-module-1-angles", "add-module", "robot"]
        )
    ),
    "meta": st.tuples(st.sampled_from(META_VARIANTS)),
    "edge": st.tuples(st.sampled_from(EDGE_VARIANTS), U),
    "file": st.tuples(
        st.sampled_from(
            [
                "truncate",
                "bom",
                "semicolon",
                "tab",
                *CSV_TEXT_EDITS,
                "sidecar-truncated",
                "sidecar-nan",
                "sidecar-empty",
                "sidecar-latin-1",
                "parquet-meta-garbage",
                "parquet-meta-deep",
            ]
        ),
        st.floats(0.0, 0.99),
    ),
}

APPLY = {
    "dtype": d_dtype,
    "nan-inf": d_nonfinite,
    "rows": d_rows,
    "time": d_time,
    "missing-column": d_missing_column,
    "extra-column": d_extra_column,
    "duplicate-column": d_duplicate_column,
    "degrees": d_degrees,
    "tension": d_tension,
    "huge": d_huge,
    "mismatched-n": d_mismatched_n,
    "meta": d_meta,
    "edge": d_edge,
    "file": d_file,
}


def defect(kind: str) -> st.SearchStrategy:
    """One defect of ``kind``: a ``(kind, params)`` tuple."""
    return KINDS[kind].map(lambda params: (kind, params))


def any_defect() -> st.SearchStrategy:
    return st.one_of(*[defect(k) for k in KINDS])


@st.composite
def documents(draw, kinds: list[str] | None = None, max_defects: int = 4):
    """A valid base recording with one to ``max_defects`` defects: ``(doc, [(kind, params), ...])``."""
    n = draw(st.sampled_from([2, 3]))
    fmt = draw(st.sampled_from(["parquet", "csv"]))
    pool = st.one_of(*[defect(k) for k in kinds]) if kinds else any_defect()
    specs = draw(st.lists(pool, min_size=1, max_size=max_defects))
    doc = base_doc(n, fmt)
    for kind, params in specs:
        APPLY[kind](doc, *params)
    return doc, specs


def label(spec: tuple[str, tuple]) -> str:
    """``kind:variant`` of a defect, for the tally."""
    kind, params = spec
    first = params[0] if params else ""
    if isinstance(first, str) and kind not in ("missing-column",):
        return f"{kind}:{first}"
    if kind in ("nan-inf", "huge", "tension"):
        return f"{kind}:{first!r}"
    return kind
