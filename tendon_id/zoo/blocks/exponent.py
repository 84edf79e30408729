"""Exponent-stage blocks: friction multipliers on the capstan exponent ``phi`` (paper Eqs. (4)–(6))."""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import NDArray

from friction_models import dead_zone_wrap, guide_wear_factors, hard_contact_gate, speed_factor
from tendon_id.checks import check_choice
from tendon_id.errors import ConfigError
from tendon_id.sliding import sliding_speed
from tendon_id.zoo.blocks.base import Block
from tendon_id.zoo.blocks.geometric import CLEARANCE_BOUNDS, CLEARANCE_START, clearance_start

#: Most worn guides a localised wear candidate names.
MAX_WORN_GUIDES = 3
#: How the clearance acts (the simulator's ``contact.gate``, :doc:`/guide/simulator`).
GATES = ("dead_zone", "hard")


@dataclass(frozen=True)
class ContactGate(Block):
    """Contact through a hole's clearance ``alpha_c`` [rad], fitted (paper Eq. (6), ref. [10]).

    ``gate="dead_zone"`` (default): the tendon turns freely through the clearance and presses on
    the wall only by the rest of its turn, ``phi = mu(alpha) max(alpha - alpha_c, 0)``
    (:func:`friction_models.dead_zone_wrap`).  ``gate="hard"``: the paper's gate on the whole
    wrap, ``phi = mu(alpha) alpha 1[alpha > alpha_c]``.  Either is a friction multiplier,
    ``max(alpha - alpha_c, 0) / alpha`` or ``1[alpha > alpha_c]``, so a fixed clearance keeps
    the law problem linear; the clearance itself is fitted within :data:`CLEARANCE_BOUNDS`
    (:mod:`tendon_id.zoo.blocks.geometric`).

    Parameters
    ----------
    alpha_c : float, optional
        Clearance angle [rad]: the start of the fit, or the value held with ``fixed=True``.
        None (default): from the robot's measured sizes
        (:func:`~tendon_id.zoo.blocks.geometric.clearance_start`), never from its metadata's
        ``alpha_c``, which is the simulator's truth.
    gate : {"dead_zone", "hard"}
        How the clearance acts (a setting, not fitted).
    """

    name = "contact"
    effect = "contact"
    stage = "exponent"
    geometric = True
    regressor = "friction of the guides inside the clearance: residual at small wraps"
    alpha_c: float | None = None
    gate: str = "dead_zone"
    param_names: tuple[str, ...] = ("alpha_c",)
    bounds: dict = field(default_factory=lambda: {"alpha_c": CLEARANCE_BOUNDS})
    probe: dict = field(default_factory=lambda: {"alpha_c": CLEARANCE_START}, compare=False, repr=False)

    def __post_init__(self) -> None:
        check_choice("contact.gate", self.gate, GATES, what="contact gate")

    def initial(self) -> dict[str, float]:
        return {"alpha_c": CLEARANCE_START if self.alpha_c is None else float(self.alpha_c)}

    def neutral(self) -> dict[str, float]:
        # No clearance: every wrap presses on the wall, which is the capstan without a gate.
        return {"alpha_c": 0.0}

    def settings(self) -> dict:
        return {"gate": self.gate}

    def started_from(self, geometry) -> ContactGate:
        return self if self.alpha_c is not None else replace(self, alpha_c=clearance_start(geometry))

    def exponent(self, phi: NDArray, ctx, values: dict) -> NDArray:
        alpha = ctx.alpha
        alpha_c = max(float(values["alpha_c"]), 0.0)  # an optimiser's rounding below the bound is no clearance
        if self.gate == "hard":
            return phi * hard_contact_gate(alpha, alpha_c)
        # In place (the bits of divide(dead_zone, alpha, out=zeros, where=alpha > 0) times phi): two fewer
        # arrays of the wrap's size at each evaluation, a sixth of a snake's recording each.
        share = dead_zone_wrap(alpha, alpha_c)
        np.divide(share, alpha, out=share, where=alpha > 0)
        share[~(alpha > 0)] = 0.0
        if np.broadcast_shapes(np.shape(phi), share.shape) != share.shape:
            return phi * share
        return np.multiply(phi, share, out=share)


@dataclass(frozen=True)
class VelocityFriction(Block):
    """Friction that changes with the tendon's sliding speed ``v`` [m/s], by its slope at rest.

    ``mu(v) = mu (1 + viscous * v)`` for ``viscous >= 0``: the simulator's ``velocity_friction``
    (:doc:`/guide/simulator`) without its Stribeck dip, ``viscous = 1 / v_ref``.  A negative
    ``viscous`` is velocity weakening, ``mu exp(viscous * v)``: friction that falls once the tendon
    slides, which the family covers in a form other than the simulator's Stribeck dip
    (:func:`friction_models.speed_factor`).  The speed is the rate at which the tendon's path
    beyond the guide changes length (:func:`tendon_id.sliding.sliding_speed`).

    Parameters
    ----------
    viscous : float
        Relative change of mu per unit sliding speed at rest [s/m], within ``(-1000, 2000)``; 0
        is Coulomb friction.  -1000 s/m is a fall of 63 % by 1 mm/s.
    """

    name = "velocity_friction"
    effect = "velocity_friction"
    stage = "exponent"
    per_tendon = True
    regressor = "exponent times sliding speed: residual grows with joint speed"
    viscous: float = 0.0
    param_names: tuple[str, ...] = ("viscous",)
    bounds: dict = field(default_factory=lambda: {"viscous": (-1000.0, 2000.0)})
    probe: dict = field(default_factory=lambda: {"viscous": 200.0}, compare=False, repr=False)

    def exponent(self, phi: NDArray, ctx, values: dict) -> NDArray:
        inputs = ctx.inputs
        speed = inputs.memo(
            "sliding_speed", lambda: sliding_speed(inputs.angles, inputs.geometry, inputs.reset, inputs.dt)
        )  # (T, K, N, 3)
        v = speed[:, :, ctx.sets][..., ctx.tendons]
        return phi * speed_factor(v, values["viscous"])


@dataclass(frozen=True)
class GuideWear(Block):
    """Friction multipliers ``1 + wear_k`` at chosen guides (:doc:`/guide/simulator` ``guide_wear``).

    Parameters
    ----------
    guides : tuple of int
        1-based guides that may be worn (a setting, not fitted).
    excess : tuple of float
        ``wear_k``, the excess friction factor per guide [-], >= 0; 0 is unworn.
    """

    name = "guide_wear"
    effect = "guide_wear"
    stage = "exponent"
    regressor = "exponent of one guide: residual follows that guide's wrap only"
    guides: tuple[int, ...] = ()
    excess: tuple[float, ...] = ()

    def __post_init__(self) -> None:
        guides = tuple(int(g) for g in self.guides)
        if any(g < 1 for g in guides) or len(set(guides)) != len(guides):
            raise ConfigError(f"guide_wear.guides must be distinct guide numbers >= 1, got {self.guides!r}")
        excess = tuple(float(e) for e in self.excess) or (0.0,) * len(guides)
        if len(excess) != len(guides):
            raise ConfigError("guide_wear needs one excess factor per guide")
        object.__setattr__(self, "guides", guides)
        object.__setattr__(self, "excess", excess)
        object.__setattr__(self, "param_names", tuple(f"wear_{g}" for g in guides))
        # Wear roughens a guide: it adds friction (an excess below 0 would be a polished guide).
        object.__setattr__(self, "bounds", {f"wear_{g}": (0.0, 4.0) for g in guides})
        object.__setattr__(self, "probe", {f"wear_{g}": 0.2 for g in guides})

    def initial(self) -> dict[str, float]:
        return {f"wear_{g}": e for g, e in zip(self.guides, self.excess)}

    def neutral(self) -> dict[str, float]:
        return {f"wear_{g}": 0.0 for g in self.guides}

    def location(self) -> str:
        return f"guide{'s' if len(self.guides) > 1 else ''} {', '.join(map(str, self.guides))}" if self.guides else ""

    def settings(self) -> dict:
        return {"guides": list(self.guides)}

    @classmethod
    def from_dict(cls, d: dict) -> GuideWear:
        d = dict(d)
        guides = tuple(int(g) for g in d.pop("guides", ()))
        excess = tuple(float(d.pop(f"wear_{g}", 0.0)) for g in guides)
        return cls(guides=guides, excess=excess, **d)

    def exponent(self, phi: NDArray, ctx, values: dict) -> NDArray:
        k = phi.shape[1]
        if self.guides and max(self.guides) > k:
            raise ConfigError(f"guide_wear names guide {max(self.guides)} but the robot has {k} guides")
        w = guide_wear_factors(k, {g: 1.0 + values[f"wear_{g}"] for g in self.guides})
        return phi * w[None, :, None, None]

    @classmethod
    def localise(cls, model, inputs, A, B, values, residual: NDArray) -> GuideWear:
        """The worn guides that explain ``residual`` best, by forward selection on their signatures.

        Each guide's column is the change of the terminal reading when that guide alone
        wears by its probe.  The law's own sensitivities (to ``A`` and ``B``, per tendon)
        are always in the fit, since a refit moves the law too: a guide is chosen for what
        its wear does that a change of the law cannot.  Guides are added while the Bayesian
        information criterion of the least-squares fit of the residual falls (Schwarz
        1978), with the frame count divided by 20 frames (2 s at 10 Hz) because residuals
        of a slowly varying mismatch are correlated; at most :data:`MAX_WORN_GUIDES`.
        """
        k = inputs.n_modules - 1
        probe = cls(guides=tuple(range(1, k + 1)))
        cols = probe.signature(model, inputs, A, B, values)
        X = np.stack([c.ravel() for c in cols.values()], axis=1)  # (nT, K) for n tendons per set
        law = _law_columns(model, inputs, A, B, values)  # (nT, 2n)
        y = np.asarray(residual, dtype=float).ravel()
        ok = np.isfinite(y) & np.all(np.isfinite(X), axis=1) & np.all(np.isfinite(law), axis=1)
        X, y, law = X[ok], y[ok], law[ok]
        n_eff = max(len(y) / 20.0, 2.0)

        def bic(cols_: list[int]) -> float:
            D = np.concatenate([law, X[:, cols_]], axis=1)
            coef = np.linalg.lstsq(D, y, rcond=None)[0]
            if cols_ and coef[-1] <= 0:  # wear only adds friction: a guide that would need less is no worn guide
                return np.inf
            sse = float(np.sum((y - D @ coef) ** 2))
            return n_eff * np.log(max(sse, 1e-300) / len(y)) + len(cols_) * np.log(n_eff)

        chosen: list[int] = []
        current = bic(chosen)
        while len(chosen) < MAX_WORN_GUIDES:
            trials = {j: bic(chosen + [j]) for j in range(k) if j not in chosen}
            j, score = min(trials.items(), key=lambda kv: kv[1])
            if score >= current:
                break
            chosen.append(j)
            current = score
        if not chosen:  # nothing stands out: the single best guide, so the candidate can still be tried
            chosen = [int(np.argmax([(X[:, j] @ y) / (np.linalg.norm(X[:, j]) + 1e-300) for j in range(k)]))]
        return cls(guides=tuple(sorted(j + 1 for j in chosen)))


def _law_columns(model, inputs, A: NDArray, B: NDArray, values: dict, step: float = 1e-3) -> NDArray:
    """Sensitivity of the terminal reading [N] to each tendon's law, shape (nT, 2n) for n tendons per set.

    ``A`` and ``B`` of every guide group move together; rows are the flattened ``(T, n)``
    reading, and tendon ``i``'s law moves only its own rows.
    """
    base = model.terminal_reading(inputs, A, B, values)
    dA = (model.terminal_reading(inputs, A + step, B, values) - base) / step
    dB = (model.terminal_reading(inputs, A, B + step, values) - base) / step
    n = base.shape[1]
    cols = np.zeros(base.shape + (2 * n,))
    for i in range(n):
        cols[:, i, 2 * i] = dA[:, i]
        cols[:, i, 2 * i + 1] = dB[:, i]
    return cols.reshape(-1, 2 * n)
