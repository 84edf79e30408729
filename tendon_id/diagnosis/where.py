"""Where the gap lies: the held-out residual of the base model broken down by stratum.

Each stratum is a set of frames (or frame-tendon pairs) of one regime: one guide bent
far, just after a reversal of the tension, a band of total wrap, of joint speed, of
tension, a stretch of the session clock, or the first seconds of each log.  For each the
diagnosis reports the share of the squared error it holds against its share of the frames
(a stratum holding 40 % of the error in 10 % of the frames is where the model is wrong)
and its mean bias.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from friction_models import play_operator
from tendon_id.diagnosis.stats import bootstrap_ci
from tendon_id.geometry import backward_rate

#: Half-width of the log-tension band a tension must cross after a reversal to leave the
#: "near reversal" stratum [-] (5 %: a few times the stick band of one guide).
REVERSAL_BAND = 0.05


@dataclass(frozen=True)
class Stratum:
    """One row of the gap map.

    Attributes
    ----------
    stratum : str
        What the frames have in common.
    kind : str
        ``guide``, ``reversal``, ``wrap``, ``speed``, ``tension``, ``time`` or ``start``.
    share_error : float
        Its share of the held-out squared error [-].
    share_frames : float
        Its share of the held-out frames (frame-tendon pairs) [-].
    bias : float
        Mean residual, measured minus predicted [N].
    bias_ci : tuple of float
        Block-bootstrap interval of the bias [N].
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
    edges = np.nanquantile(x[rest], [0.0, 0.25, 0.5, 0.75, 1.0])
    for q in range(4):
        a, b = edges[q], edges[q + 1]
        mask = rest & (x >= a) & ((x < b) if q < 3 else (x <= b))
        out.append((f"{label} Q{q + 1} ({a * scale:.3g}–{b * scale:.3g} {unit})", mask))
    return out


def strata_masks(inputs) -> list[tuple[str, str, NDArray]]:
    """``(name, kind, mask)`` of every stratum; masks have shape (T,) or (T, 3).

    Parameters
    ----------
    inputs : TransmissionInputs
        The held-out data.
    """
    out: list[tuple[str, str, NDArray]] = []
    wrap = inputs.wrap  # (T, K)
    for k in range(wrap.shape[1]):
        w = wrap[:, k]
        top = np.quantile(w, 0.75)
        if np.ptp(w) > 1e-3 and (w > top).any():
            out.append((f"guide {k + 1} bent (wrap > {top:.3f} rad)", "guide", w > top))
    # Near reversals: a play operator on the actuator tension sticks (sigma = 0) from a
    # reversal until the tension has moved 2 * REVERSAL_BAND in log away from it.
    act = inputs.actuator[:, -1]  # (T, 3): the terminal set, the one the labels see
    stuck = play_operator(np.log(act), REVERSAL_BAND, inputs.reset).sigma == 0
    out.append(("near tension reversals", "reversal", stuck))
    out.append(("away from tension reversals", "reversal", ~stuck))
    for name, mask in quartile_masks(wrap.sum(axis=1), "total wrap", "rad"):
        out.append((name, "wrap", mask))
    speed = np.abs(backward_rate(inputs.angles, inputs.reset, inputs.dt)).max(axis=(1, 2))
    rest = "joints at rest" if speed.min() == 0 else None
    for name, mask in quartile_masks(speed, "joint speed", "deg/s", np.degrees(1.0), least=rest):
        out.append((name, "speed", mask))
    for name, mask in quartile_masks(act, "actuator tension", "N"):
        out.append((name, "tension", mask))
    for name, mask in quartile_masks(inputs.clock, "session clock", "s"):
        out.append((name, "time", mask))
    # The first seconds of each log: a model that guesses the stick/slip and lag state at a
    # log's start is wrong there until the state is forgotten.
    for name, mask in quartile_masks(inputs.since_start, "time since log start", "s"):
        out.append((name, "start", mask))
    return out


def gap_map(inputs, residual: NDArray, *, block: int, n_boot: int, level: float, rng, masks=None) -> list[Stratum]:
    """The strata of :func:`strata_masks` (or ``masks``) with their error shares and biases.

    Parameters
    ----------
    inputs : TransmissionInputs
        Held-out data.
    masks : list of (name, kind, mask), optional
        Strata of another data kind (a bench passage's).
    residual : ndarray, shape (T, 3)
        Measured minus predicted terminal reading of the base [N].
    block : int
        Bootstrap block length [frames].
    """
    sq = residual**2
    total = float(np.nansum(sq))
    n_all = int(np.isfinite(residual).sum())
    rows = []
    valid = np.isfinite(residual)  # NaN in the model's warm-up
    for name, kind, mask in strata_masks(inputs) if masks is None else masks:
        m = np.broadcast_to(mask if mask.ndim == 2 else mask[:, None], residual.shape) & valid
        if not m.any():
            continue
        frames = m.any(axis=1)
        per_frame = np.nanmean(np.where(m, residual, np.nan)[frames], axis=1)  # mean bias of each frame
        ci = bootstrap_ci(per_frame, block, n_boot, level, rng)
        rows.append(
            Stratum(
                stratum=name,
                kind=kind,
                share_error=float(np.nansum(sq[m]) / total) if total > 0 else 0.0,
                share_frames=float(m.sum() / n_all),
                bias=float(np.nanmean(residual[m])),
                bias_ci=ci,
            )
        )
    return rows
