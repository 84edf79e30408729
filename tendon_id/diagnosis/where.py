"""Where the gap lies: the held-out residual of the base model broken down by stratum.

Each stratum is a set of frames (or frame-channel pairs) of one regime, which the family
defines (:meth:`~tendon_id.family.Family.strata`): for the snake chain one guide bent far, just
after a reversal of the tension, a band of total wrap, of joint speed, of tension, a stretch of
the session clock, or the first seconds of each log.  For each the diagnosis reports the share
of the squared error it holds against its share of the frames (a stratum holding 40 % of the
error in 10 % of the frames is where the model is wrong) and its mean bias.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from tendon_id.diagnosis.moments import nan_sum_square
from tendon_id.diagnosis.stats import bootstrap_ci


@dataclass(frozen=True)
class Stratum:
    """One row of the gap map.

    Attributes
    ----------
    stratum : str
        What the frames have in common.
    kind : str
        What kind of regime (the family's: ``guide``, ``reversal``, ``wrap``, ``speed``,
        ``tension``, ``load``, ``position``, ``time`` or ``start``).
    share_error : float
        Its share of the held-out squared error [-].
    share_frames : float
        Its share of the held-out frames (frame-tendon pairs) [-].
    bias : float
        Mean residual, measured minus predicted [the family's unit].
    bias_ci : tuple of float
        Block-bootstrap interval of the bias.
    """

    stratum: str
    kind: str
    share_error: float
    share_frames: float
    bias: float
    bias_ci: tuple[float, float]

    @property
    def concentration(self) -> float:
        """``share_error / share_frames``: above 1 where the error is concentrated."""
        return self.share_error / self.share_frames if self.share_frames > 0 else float("nan")

    def to_dict(self) -> dict:
        return {
            "stratum": self.stratum,
            "kind": self.kind,
            "share_error": self.share_error,
            "share_frames": self.share_frames,
            "bias": self.bias,
            "bias_ci": list(self.bias_ci),
        }


def quartile_masks(
    x: NDArray, label: str, unit: str, scale: float = 1.0, least: str | None = None
) -> list[tuple[str, NDArray]]:
    """Quartile bands of ``x``, with its least value apart when over a quarter of the frames hold it.

    A joint is at rest in many frames of a held-pose log (its encoder reading does not
    change), so its speed is 0 in, say, 70 % of them; quartile edges would then coincide and
    the bands would be empty or lumped.  Those frames become one stratum (named ``least``),
    and the quartiles are those of the rest.

    Parameters
    ----------
    x : ndarray, shape (T,)
        The variable per frame, in SI units.
    label, unit : str
        Its name, and the unit of ``x * scale``.
    scale : float
        Factor from SI to the unit shown.
    least : str, optional
        Name of the stratum of the least value (default: ``"{label} = {min} {unit}"``).
    """
    lo = np.nanmin(x)
    if np.nanmax(x) - lo <= 1e-12 * max(1.0, abs(lo)):
        return []
    out = []
    rest = np.ones(x.shape, dtype=bool)
    at_least = x <= lo
    if at_least.mean() > 0.25:
        out.append((least or f"{label} = {lo * scale:.3g} {unit}", at_least))
        rest = ~at_least
    # x[rest] is a copy of our own: the quantiles may partition it in place, not copy it again.
    edges = np.nanquantile(x[rest], [0.0, 0.25, 0.5, 0.75, 1.0], overwrite_input=True)
    for q in range(4):
        a, b = edges[q], edges[q + 1]
        mask = rest & (x >= a) & ((x < b) if q < 3 else (x <= b))
        out.append((f"{label} Q{q + 1} ({a * scale:.3g}–{b * scale:.3g} {unit})", mask))
    return out


def gap_map(inputs, residual: NDArray, masks, *, block: int, n_boot: int, level: float, rng) -> list[Stratum]:
    """The strata ``masks`` with their error shares and biases.

    Parameters
    ----------
    inputs : FrameInputs
        Held-out data.
    residual : ndarray, shape (T, C)
        Measured minus predicted reading of the base, NaN in its warm-up.
    masks : iterable of (name, kind, mask)
        The family's strata (:meth:`~tendon_id.family.Family.strata`), read once, in order; a
        mask has shape (T,) or (T, C).
    block : int
        Bootstrap block length [frames].
    """
    # Whole-length temporaries are made one at a time: at an hour of 1 kHz each is 27 MiB a channel.
    total = nan_sum_square(residual)
    valid = np.isfinite(residual)  # NaN in the model's warm-up
    n_all = int(valid.sum())
    rows = []
    for name, kind, mask in masks:
        m = np.broadcast_to(mask if mask.ndim == 2 else mask[:, None], residual.shape) & valid
        if not m.any():
            continue
        frames = m.any(axis=1)
        w = m[frames]
        # Each frame's mean bias over its channels in the stratum: nanmean's sum and count, without its copies.
        per_frame = np.where(w, residual[frames], 0.0).sum(axis=1) / w.sum(axis=1, dtype=np.intp)
        del w, frames
        ci = bootstrap_ci(per_frame, block, n_boot, level, rng, overwrite_input=True)
        del per_frame
        picked = residual[m]
        rows.append(
            Stratum(
                stratum=name,
                kind=kind,
                share_error=float(np.nansum(picked**2) / total) if total > 0 else 0.0,
                share_frames=float(m.sum() / n_all),
                bias=float(np.nanmean(picked)),
                bias_ci=ci,
            )
        )
    return rows
