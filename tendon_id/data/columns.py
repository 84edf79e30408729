"""One column of a recording's frame, whatever its family: its values as float64, and the sample rate.

Used by every recording (:class:`~tendon_id.data.frame.FrameRecording`) and the rules
(:mod:`tendon_id.data.rules`); nothing here knows a family's columns.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import pandas as pd

__all__ = ["DEFAULT_SAMPLE_RATE_HZ", "PANDAS_COW", "float_column", "infer_sample_rate", "is_int", "is_real_dtype"]

#: Sample rate [Hz] assumed when the metadata does not give one and the time column cannot tell.
DEFAULT_SAMPLE_RATE_HZ = 10.0

#: True under pandas >= 3, where copy-on-write is always on (copies are lazy and safe).
PANDAS_COW = int(pd.__version__.split(".")[0]) >= 3


def is_int(x: Any) -> bool:
    """True for a Python or numpy integer, False for bools (which are ints to Python)."""
    return isinstance(x, (int, np.integer)) and not isinstance(x, (bool, np.bool_))


def is_real_dtype(dtype: Any) -> bool:
    """True for integer or floating dtypes (numpy or pandas nullable), False for bool/str/complex."""
    kind = getattr(dtype, "kind", None)
    return kind in ("i", "u", "f")


def float_column(frame: pd.DataFrame, column: str) -> np.ndarray:
    """A column as float64 (missing values as NaN); float64 columns are not copied."""
    s = frame[column]
    if isinstance(s.dtype, np.dtype) and s.dtype == np.float64:
        return s.to_numpy()
    return s.to_numpy(dtype=np.float64, na_value=np.nan)


def infer_sample_rate(frame: pd.DataFrame) -> float:
    """Sample rate [Hz] from the median positive time step within trajectories.

    Falls back to :data:`DEFAULT_SAMPLE_RATE_HZ` when the frame has no
    usable time steps (missing columns, one frame, non-numeric time).
    """
    f = frame
    try:
        if "t" not in f.columns or "trajectory" not in f.columns or len(f) < 2:
            return DEFAULT_SAMPLE_RATE_HZ
        t = float_column(f, "t")
        tr = f["trajectory"].to_numpy()
        d = np.diff(t)[tr[1:] == tr[:-1]]
        d = d[np.isfinite(d) & (d > 0)]
        if d.size == 0:
            return DEFAULT_SAMPLE_RATE_HZ
        # 6 significant digits: 9.9999999 Hz from float round-off reads as 10 Hz.
        return float(f"{1.0 / float(np.median(d)):.6g}")
    except (TypeError, ValueError):
        return DEFAULT_SAMPLE_RATE_HZ
