"""The capstan models of the snake chain: transmission hypotheses built from effect blocks.

The capstan models propagate ``ln T`` of every tendon through the guides with
exponent ``phi = mu_i(alpha_k) alpha_k`` (paper Eqs. (4)–(6)) and the blocks of
:mod:`tendon_id.zoo.blocks`:

=====================  ==========================  ==========================
name                   friction law                blocks
=====================  ==========================  ==========================
``capstan-simple``     affine-cosine, Eq. (4)      none (beta = sigma = 1)
``capstan-contact``    affine-cosine               contact gate
``capstan-nonsmooth``  affine-cosine               contact gate, hysteresis
``capstan-const-mu``   constant mu (Euler–Eytelwein)  none
=====================  ==========================  ==========================

``tying="tied"`` shares ``(A_i, B_i)`` over guides (the paper's assumption of
tribological homogeneity); ``"per-guide"`` gives each guide its own.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from tendon_id.calibration.law import calibrate_capstan
from tendon_id.checks import check_choice, check_count, check_positive
from tendon_id.data import Recording
from tendon_id.errors import ConfigError
from tendon_id.geometry import RobotGeometry
from tendon_id.zoo.base import TransmissionModel
from tendon_id.zoo.blocks import Block, HookContext, as_block, block_from_dict, compose
from tendon_id.zoo.chain import ExponentTerms, apply_sensor, exponent, exponent_terms, propagate_chain
from tendon_id.zoo.inputs import TransmissionInputs, as_recordings

MU_LAWS = ("affine-cosine", "constant")
TYINGS = ("tied", "per-guide")


class CapstanModel(TransmissionModel):
    """Capstan transmission ``T[k+1] = exp(-phi) T[k]`` with composable effect blocks.

    Parameters
    ----------
    mu_law : {"affine-cosine", "constant"}
        ``mu_i(alpha) = A_i cos(alpha) + B_i`` (paper Eq. (4)) or a constant ``mu_i``.
    blocks : sequence of Block or str
        Effect blocks (:mod:`tendon_id.zoo.blocks`), e.g. ``("contact", "hysteresis")``.
    tying : {"tied", "per-guide"}
        Share the law over guides, or give each guide its own.
    robot : dict, optional
        Robot description; default: from the data's metadata.
    n_starts : int
        Optimiser starts for nonsmooth models (the first is the smooth solution).
    seed : int
        Seed of the extra starts.
    xtol_rel : float
        Relative parameter tolerance of the derivative-free (nonsmooth) fits; smooth
        fits are solved to 1e-10.
    maxeval : int
        Objective evaluations per start (nonsmooth models).
    warmup_s : float
        Seconds at the start of every trajectory left out of the calibration loss [s].
        A log starts in an unknown stick/slip state, which the model replaces by forward
        slip; a warm-up lets the hysteresis forget that guess before frames count.
        0 (the paper's baseline) uses every frame.

    Attributes
    ----------
    A_, B_ : ndarray, shape (G, 3)
        Fitted law, ``G = 1`` (tied) or ``N - 1`` (per-guide); ``A_`` is zero for
        the constant law and ``B_`` is then ``mu``.
    block_values_ : dict
        Fitted free block parameters, ``{block name: {param: value}}`` (what is saved).
    block_params_ : dict
        Every block's parameters at the fitted state (the free ones from ``block_values_``):
        the ``values`` the forward model runs with.
    calibration_ : dict
        Summary of the calibration (loss, optimiser status, evaluations, seconds).
    geometry_ : RobotGeometry
    n_modules_ : int
    """

    name = "capstan"

    def __init__(
        self,
        mu_law: str = "affine-cosine",
        blocks: Sequence[Block | str] = (),
        tying: str = "tied",
        robot: dict | None = None,
        n_starts: int = 3,
        seed: int = 0,
        xtol_rel: float = 1e-3,
        maxeval: int = 400,
        warmup_s: float = 0.0,
    ):
        self.mu_law = mu_law
        self.blocks = blocks
        self.tying = tying
        self.robot = robot
        self.n_starts = n_starts
        self.seed = seed
        self.xtol_rel = xtol_rel
        self.maxeval = maxeval
        self.warmup_s = warmup_s

    # ---- structure -----------------------------------------------------------
    def check_settings(self) -> None:
        self._validated()

    def _validated(self) -> tuple[Block, ...]:
        check_choice("mu_law", self.mu_law, MU_LAWS, what="friction law")
        check_choice("tying", self.tying, TYINGS)
        check_count("n_starts", self.n_starts, 1)
        check_count("maxeval", self.maxeval, 10)
        check_positive("warmup_s", self.warmup_s, "s", allow_zero=True)
        return compose(self.blocks)

    @property
    def block_objects(self) -> tuple[Block, ...]:
        """The blocks as objects (``blocks`` may hold names)."""
        return self._validated()

    def with_blocks(self, *extra: Block | str) -> CapstanModel:
        """An unfitted copy of this model with ``extra`` blocks added (the diagnosis uses this)."""
        params = {**self.get_params(), "mu_law": self.mu_law}
        params["blocks"] = tuple(self.block_objects) + tuple(as_block(b) for b in extra)
        return CapstanModel(**params)

    def smooth_part(self) -> CapstanModel:
        """An unfitted model of this one's law and tendon-independent exponent blocks: its part linear in the law."""
        blocks = [b for b in self.block_objects if b.stage == "exponent" and not b.per_tendon]
        return CapstanModel(mu_law=self.mu_law, blocks=blocks, tying=self.tying)

    def free_parameters(self) -> list[tuple[str, str, tuple[float, float], float]]:
        """Block parameters calibrated with the law: ``(block, param, bounds, initial)``."""
        out = []
        for b in self.block_objects:
            if b.fixed:
                continue
            for p, v in b.initial().items():
                out.append((b.name, p, tuple(b.bounds[p]), float(v)))
        return out

    @property
    def is_smooth(self) -> bool:
        """True when ``ln T_N`` is linear in the law: only tendon-independent exponent blocks, none free."""
        nonlinear = any(b.stage != "exponent" or b.per_tendon for b in self.block_objects)
        return not nonlinear and not self.free_parameters()

    # ---- forward model (tendon_id.zoo.chain) ------------------------------------------
    def block_params(self, overrides: dict | None = None) -> dict[str, dict[str, float]]:
        """Every block's parameters ``{block: {param: value}}``: the blocks' own values, updated by ``overrides``.

        This is the ``values`` argument of :meth:`exponent`, :meth:`propagate` and
        :meth:`terminal_reading`; a fitted model's are :attr:`block_params_`.
        """
        vals = {b.name: b.initial() for b in self.block_objects}
        for name, d in (overrides or {}).items():
            vals.setdefault(name, {}).update(d)
        return vals

    def exponent_multiplier(self, inputs: TransmissionInputs, values: dict | None = None) -> NDArray:
        """Product of the tendon-independent exponent blocks' factors at the backbone wrap, shape (T, N-1, 1).

        The linear design of :class:`~tendon_id.calibration.problem.LawProblem` uses it; per-tendon blocks
        (wraps, sliding speeds) count as 1 there.
        """
        values = self.block_params() if values is None else values
        ctx = HookContext(inputs, np.array([inputs.n_modules - 1]), np.arange(3), alpha=inputs.wrap[:, :, None, None])
        m = np.ones(inputs.wrap.shape + (1, 1))
        for b in self.block_objects:
            if b.stage == "exponent" and not b.per_tendon:
                m = b.exponent(m, ctx, values.get(b.name, {}))
        return m[..., 0]

    def exponent_terms(
        self,
        inputs: TransmissionInputs,
        values: dict | None = None,
        sets: NDArray | None = None,
        tendons: NDArray | None = None,
    ) -> ExponentTerms:
        """The law-free part of the exponent (wrap and exponent blocks), reusable while only the law changes."""
        return exponent_terms(self.block_objects, inputs, *self._chain_defaults(inputs, values, sets, tendons))

    def _chain_defaults(self, inputs, values, sets, tendons) -> tuple[dict, NDArray, NDArray]:
        """``values``, ``sets`` and ``tendons`` with their defaults: the blocks' values, every set, every tendon."""
        values = self.block_params() if values is None else values
        sets = np.arange(inputs.n_modules) if sets is None else np.asarray(sets)
        tendons = np.arange(3) if tendons is None else np.asarray(tendons)
        return values, sets, tendons

    def exponent(self, inputs: TransmissionInputs, A: NDArray, B: NDArray, values: dict | None = None) -> NDArray:
        """Capstan exponent ``phi[t, k, j, i]`` (paper Eq. (5) with the blocks), shape (T, N-1, N|1, m).

        ``A``, ``B`` have shape (G, m) for ``m`` tendons; the constant law uses ``B`` as mu.
        The set axis has length 1 unless a block makes the exponent depend on the set.
        """
        return exponent(self.mu_law, self.exponent_terms(inputs, values, tendons=np.arange(A.shape[1])), A, B)

    def propagate(
        self,
        inputs: TransmissionInputs,
        A: NDArray,
        B: NDArray,
        values: dict | None = None,
        *,
        sets: NDArray | None = None,
        tendons: NDArray | None = None,
        keep_chain: bool = True,
        terms: ExponentTerms | None = None,
    ) -> NDArray:
        """Propagate ``ln T`` through the guides (paper Algorithm 1 with analytic ratios).

        Parameters
        ----------
        inputs : TransmissionInputs
        A, B : ndarray, shape (G, m)
            Law per guide (G = 1 tied) for the ``m`` tendons in ``tendons``.
        values : dict, optional
            Block parameters.
        sets : ndarray of int, optional
            0-based set indices to propagate (default all).
        tendons : ndarray of int, optional
            0-based tendon indices (default all three).
        keep_chain : bool
            Return the whole chain ``ln T[k, j, i]``, shape (T, N, S, m) with NaN
            off the path; else only the joint sides ``ln T[j, j, i]``, shape (T, S, m).
        terms : ExponentTerms, optional
            Precomputed :meth:`exponent_terms` for these sets and tendons.
        """
        values, sets, tendons = self._chain_defaults(inputs, values, sets, tendons)
        return propagate_chain(
            self.block_objects, self.mu_law, inputs, A, B, values, sets, tendons, keep_chain=keep_chain, terms=terms
        )

    def terminal_reading(
        self,
        inputs: TransmissionInputs,
        A: NDArray,
        B: NDArray,
        values: dict | None = None,
        tendons: NDArray | None = None,
        terms: ExponentTerms | None = None,
    ) -> NDArray:
        """Predicted terminal load-cell reading [N], shape (T, m) (the sensor blocks applied)."""
        values, sets, tendons = self._chain_defaults(inputs, values, np.array([inputs.n_modules - 1]), tendons)
        log_t = self.propagate(inputs, A, B, values, sets=sets, tendons=tendons, keep_chain=False, terms=terms)
        return apply_sensor(self.block_objects, np.exp(log_t[:, 0]), HookContext(inputs, sets, tendons), values)

    # ---- estimator API ---------------------------------------------------------------
    def fit(self, data: Recording | Sequence[Recording]) -> CapstanModel:
        """Calibrate the law (and free block parameters) on terminal-only labels with nlopt.

        Intermediate joint-side truth is removed before anything is read.
        """
        self._validated()
        recs = [r.fitting_view() for r in as_recordings(data)]
        inputs = TransmissionInputs.from_recordings(recs, self.robot)
        result = calibrate_capstan(self, inputs)
        self.A_, self.B_ = result.A, result.B
        self.block_values_ = result.block_values
        self.calibration_ = result.to_dict()
        self.geometry_ = inputs.geometry
        self.n_modules_ = inputs.n_modules
        return self

    def fitted_with(
        self, A: NDArray, B: NDArray, geometry: RobotGeometry, n_modules: int, block_values: dict | None = None
    ) -> CapstanModel:
        """An unfitted copy of this model, given a law instead of calibrating one.

        ``A``, ``B`` have shape (G, 3) or (3,) (tied); ``block_values`` are the free block
        parameters, ``{block: {param: value}}`` (default: the blocks' own).
        """
        model = type(self)(**self.get_params())
        model.A_ = np.atleast_2d(np.asarray(A, dtype=float)).copy()
        model.B_ = np.atleast_2d(np.asarray(B, dtype=float)).copy()
        model.block_values_ = {k: dict(v) for k, v in (block_values or {}).items()}
        model.calibration_ = {"given": True}
        model.geometry_, model.n_modules_ = geometry, int(n_modules)
        return model

    def inputs(self, data: Recording | Sequence[Recording]) -> TransmissionInputs:
        """The arrays the fitted model reads from ``data``, with the geometry it was fitted with.

        Raises ``NotFittedError`` before ``fit``, and ``ConfigError`` for data of another module count.
        """
        recs = self._check_data(data)
        return TransmissionInputs.from_recordings(recs, self.geometry_)

    @property
    def block_params_(self) -> dict[str, dict[str, float]]:
        """Every block's parameters at the fitted state: :attr:`block_values_` over the blocks' own values."""
        self.check_fitted()
        return self.block_params(self.block_values_)

    def predict_chain(self, data: Recording | Sequence[Recording]) -> NDArray[np.float64]:
        """Every ``T[k, j, i]`` [N], shape (T, N, N, 3), NaN where ``k > j``."""
        inputs = self.inputs(data)
        chain = np.exp(self.propagate(inputs, self.A_, self.B_, self.block_params_))
        chain[:, 0] = inputs.actuator  # the actuator side exactly, not exp(log(.))
        return chain

    def predict(self, data: Recording | Sequence[Recording]) -> NDArray[np.float64]:
        inputs = self.inputs(data)
        pred = np.exp(self.propagate(inputs, self.A_, self.B_, self.block_params_, keep_chain=False))
        pred[:, 0] = inputs.actuator[:, 0]  # set 1 passes no guide
        return pred

    def predict_terminal(self, data: Recording | Sequence[Recording]) -> NDArray[np.float64]:
        return self.terminal_reading(self.inputs(data), self.A_, self.B_, self.block_params_)

    @property
    def mu0_(self) -> NDArray[np.float64]:
        """``mu_i(0) = A_i + B_i``, shape (G, 3): what terminal data pins down best."""
        self.check_fitted()
        return self.A_ + self.B_

    # ---- persistence -------------------------------------------------------------------
    def _json_params(self) -> dict:
        p = super()._json_params()
        p["blocks"] = [b.to_dict() for b in self.block_objects]
        return p

    @classmethod
    def _from_params(cls, params: dict) -> CapstanModel:
        params = dict(params)
        params["blocks"] = tuple(block_from_dict(b) for b in params.get("blocks", []))
        return cls(**params)

    def _state(self):
        state = {
            "n_modules": self.n_modules_,
            "geometry": self.geometry_.to_dict(),
            "block_values": self.block_values_,
            "calibration": self.calibration_,
        }
        return state, {"A": self.A_, "B": self.B_}

    def _restore(self, state, arrays):
        self.n_modules_ = int(state["n_modules"])
        self.geometry_ = RobotGeometry.from_dict(state["geometry"])
        self.block_values_ = {k: dict(v) for k, v in state.get("block_values", {}).items()}
        self.calibration_ = state.get("calibration", {})
        self.A_ = np.asarray(arrays["A"], dtype=float)
        self.B_ = np.asarray(arrays["B"], dtype=float)
        rows = (1, self.n_modules_ - 1)  # a tied law, or one per guide
        if self.A_.shape != self.B_.shape or self.A_.ndim != 2 or self.A_.shape[1] != 3 or self.A_.shape[0] not in rows:
            raise ConfigError(
                f"arrays A {self.A_.shape} and B {self.B_.shape} do not fit a {self.n_modules_}-module capstan law: "
                f"both need shape (1, 3) when tied or ({self.n_modules_ - 1}, 3) per guide"
            )
        if not (np.all(np.isfinite(self.A_)) and np.all(np.isfinite(self.B_))):
            raise ConfigError("arrays A and B hold NaN or inf")


def _preset(name: str, mu_law: str, blocks: tuple[str, ...], doc: str) -> type[CapstanModel]:
    """A registered capstan variant: fixed law and blocks, everything else settable."""

    def __init__(
        self,
        tying: str = "tied",
        robot: dict | None = None,
        n_starts: int = 3,
        seed: int = 0,
        xtol_rel: float = 1e-3,
        maxeval: int = 400,
        warmup_s: float = 0.0,
        blocks: Sequence[Block | str] = blocks,
    ):
        # In CapstanModel's order: mu_law, blocks, tying, robot, n_starts, seed, xtol_rel, maxeval, warmup_s.
        CapstanModel.__init__(self, mu_law, blocks, tying, robot, n_starts, seed, xtol_rel, maxeval, warmup_s)

    cls = type(name.title().replace("-", ""), (CapstanModel,), {"name": name, "__init__": __init__, "__doc__": doc})
    cls.__module__ = __name__
    return cls


CapstanSimple = _preset(
    "capstan-simple", "affine-cosine", (), "Affine-cosine capstan with beta = sigma = 1 (paper Table I, ref. [5])."
)
CapstanContact = _preset(
    "capstan-contact",
    "affine-cosine",
    ("contact",),
    "Affine-cosine capstan with the geometric contact gate (paper ref. [10]).",
)
CapstanNonsmooth = _preset(
    "capstan-nonsmooth",
    "affine-cosine",
    ("contact", "hysteresis"),
    "Contact gate plus stick/slip hysteresis (paper ref. [12]): the paper's physics baseline.",
)
CapstanConstMu = _preset("capstan-const-mu", "constant", (), "The classic constant-mu Euler–Eytelwein capstan.")
