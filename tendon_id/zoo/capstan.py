"""The capstan models of the snake chain: transmission hypotheses built from effect blocks.

The capstan models propagate ``ln T`` of every tendon through the guides with
exponent ``phi = mu_i(alpha_k) alpha_k`` (paper Eqs. (4)–(6)) and the blocks of
:mod:`tendon_id.zoo.blocks`; every one also fits the routing wrap ``alpha_0`` of Eq. (3)
(:class:`~tendon_id.zoo.blocks.RoutingWrap`), and the contact gate the hole's clearance
``alpha_c``: a user knows neither, and a model never reads them from a recording's metadata:

=====================  ==========================  ==========================
name                   friction law                blocks
=====================  ==========================  ==========================
``capstan-simple``     affine-cosine, Eq. (4)      none (beta = sigma = 1)
``capstan-contact``    affine-cosine               contact (dead zone)
``capstan-nonsmooth``  affine-cosine               contact, hysteresis
``capstan-const-mu``   constant mu (Euler–Eytelwein)  none
=====================  ==========================  ==========================

``tying="tied"`` shares ``(A_i, B_i)`` over guides (the paper's assumption of
tribological homogeneity); ``"per-guide"`` gives each guide its own.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from tendon_id.calibration.law import calibrate_capstan
from tendon_id.data import Recording
from tendon_id.data.io import release_arrow_memory
from tendon_id.errors import ConfigError
from tendon_id.geometry import RobotGeometry
from tendon_id.zoo.base import TransmissionModel
from tendon_id.zoo.blocks import Block, ContactGate, RoutingWrap, block_from_dict, compose
from tendon_id.zoo.capstan_structure import MU_LAWS, TYINGS, CapstanStructure
from tendon_id.zoo.chain import actuator_tension
from tendon_id.zoo.inputs import TransmissionInputs, as_recordings

__all__ = [
    "MU_LAWS",
    "TYINGS",
    "CapstanConstMu",
    "CapstanContact",
    "CapstanModel",
    "CapstanNonsmooth",
    "CapstanSimple",
]


class CapstanModel(CapstanStructure, TransmissionModel):
    """Capstan transmission ``T[k+1] = exp(-phi) T[k]`` with composable effect blocks.

    Parameters
    ----------
    mu_law : {"affine-cosine", "constant"}
        ``mu_i(alpha) = A_i cos(alpha) + B_i`` (paper Eq. (4)) or a constant ``mu_i``.
    blocks : sequence of Block or str
        Effect blocks (:mod:`tendon_id.zoo.blocks`), e.g. ``("contact", "hysteresis")``.  A
        fitted routing wrap (:class:`~tendon_id.zoo.blocks.RoutingWrap`) is added unless one is
        given (``RoutingWrap(alpha_0=..., fixed=True)`` holds a known one).
    tying : {"tied", "per-guide"}
        Share the law over guides, or give each guide its own.
    robot : dict, optional
        Robot description; default: from the data's metadata.  Its sizes and azimuths are
        read, and its measured hole and tendon sizes start the clearance; never its
        ``alpha_0`` or ``alpha_c``, which are fitted.
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
    A_, B_ : ndarray, shape (G, n)
        Fitted law, ``G = 1`` (tied) or ``N - 1`` (per-guide); ``A_`` is zero for
        the constant law and ``B_`` is then ``mu``.
    block_values_ : dict
        Fitted free block parameters, ``{block name: {param: value}}`` (what is saved), the
        routing wrap's ``{"routing": {"alpha_0": ...}}`` and the contact's ``alpha_c`` included.
    block_params_ : dict
        Every block's parameters at the fitted state (the free ones from ``block_values_``):
        the ``values`` the forward model runs with.
    calibration_ : dict
        Summary of the calibration (loss, optimiser status, evaluations, seconds).
    alpha_0_ : float
        The routing wrap the model runs with [rad] (fitted unless held).
    alpha_c_ : float or None
        The clearance angle [rad] (fitted unless held); None without a contact block.
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

    @classmethod
    def general(cls) -> type[CapstanModel]:
        return CapstanModel

    # ---- estimator API ---------------------------------------------------------------
    def fit(self, data: Recording | Sequence[Recording]) -> CapstanModel:
        """Calibrate the law (and free block parameters) on terminal-only labels with nlopt.

        Intermediate joint-side truth is removed before anything is read.
        """
        self._validated()
        recs = [r.fitting_view() for r in as_recordings(data)]
        inputs = TransmissionInputs.from_recordings(recs, self.robot)
        data = recs = None  # recordings handed over (the CLI's) are freed for the calibration: it reads the arrays
        release_arrow_memory()  # their text lived in Arrow's allocator, which keeps what is freed until asked
        result = calibrate_capstan(self.started_from(inputs.geometry), inputs)
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

        ``A``, ``B`` have shape (G, n) or (n,) (tied), for ``n`` tendons per set; ``block_values`` are the free block
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

    @property
    def alpha_0_(self) -> float:
        """The routing wrap the fitted model runs with [rad]."""
        routing = next(b for b in self.block_objects if b.stage == "routing")
        return float(self.block_params_[routing.name]["alpha_0"])

    @property
    def alpha_c_(self) -> float | None:
        """The clearance angle the fitted model runs with [rad], or None without a contact block."""
        contact = [b for b in self.block_objects if isinstance(b, ContactGate)]
        return float(self.block_params_[contact[0].name]["alpha_c"]) if contact else None

    def predict_chain(self, data: Recording | Sequence[Recording]) -> NDArray[np.float64]:
        """Every ``T[k, j, i]`` [N], shape (T, N, N, n), NaN where ``k > j``."""
        inputs = self.inputs(data)
        chain = np.exp(self.propagate(inputs, self.A_, self.B_, self.block_params_))
        chain[:, 0] = self._actuator_side(inputs)  # exactly, not exp(log(.))
        return chain

    def predict(self, data: Recording | Sequence[Recording]) -> NDArray[np.float64]:
        inputs = self.inputs(data)
        pred = np.exp(self.propagate(inputs, self.A_, self.B_, self.block_params_, keep_chain=False))
        pred[:, 0] = self._actuator_side(inputs)[:, 0]  # set 1 passes no guide: exactly, not exp(log(.))
        return pred

    def _actuator_side(self, inputs) -> NDArray[np.float64]:
        # The readings, through the actuator-side blocks (a cell's gain, its lag) where the model has them.
        return actuator_tension(
            self.block_objects, inputs, self.block_params_, np.arange(inputs.n_modules), np.arange(inputs.n_tendons)
        )

    def predict_terminal(self, data: Recording | Sequence[Recording]) -> NDArray[np.float64]:
        return self.terminal_reading(self.inputs(data), self.A_, self.B_, self.block_params_)

    def streamer(self):
        """A frame-by-frame estimator, O(1) per frame (:class:`~tendon_id.zoo.capstan_stream.CapstanStream`).

        Raises ``ConfigError`` for a model with a block the frame-by-frame law does not cover
        (:data:`~tendon_id.zoo.capstan_stream.STREAMED_BLOCKS` lists those it does).
        """
        from tendon_id.zoo.capstan_stream import CapstanStream

        self.check_fitted()
        return CapstanStream(self)

    @property
    def mu0_(self) -> NDArray[np.float64]:
        """``mu_i(0) = A_i + B_i``, shape (G, n): what terminal data pins down best."""
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
        self._hold_saved_geometry()
        self.block_values_ = _block_values(state.get("block_values", {}))
        self.calibration_ = state.get("calibration", {})
        self.A_ = np.asarray(arrays["A"], dtype=float)
        self.B_ = np.asarray(arrays["B"], dtype=float)
        rows, m = (1, self.n_modules_ - 1), self.geometry_.n_tendons  # a tied law, or one per guide
        if self.A_.shape != self.B_.shape or self.A_.ndim != 2 or self.A_.shape[1] != m or self.A_.shape[0] not in rows:
            raise ConfigError(
                f"arrays A {self.A_.shape} and B {self.B_.shape} do not fit a {self.n_modules_}-module capstan law: "
                f"both need shape (1, {m}) when tied or ({self.n_modules_ - 1}, {m}) per guide"
            )
        if not (np.all(np.isfinite(self.A_)) and np.all(np.isfinite(self.B_))):
            raise ConfigError("arrays A and B hold NaN or inf")
        # mu(alpha) = A cos(alpha) + B >= 0 on [0, pi] iff B >= |A| (friction_models.mu_laws); the
        # calibration keeps every law there, so a law outside is a damaged or hand-made file.
        slack = 1e-12 * max(1.0, float(np.max(np.abs(self.A_))))
        if self.mu_law == "affine-cosine" and np.any(self.B_ < np.abs(self.A_) - slack):
            g, i = np.argwhere(self.B_ < np.abs(self.A_) - slack)[0]
            raise ConfigError(
                f"arrays A and B give a negative friction coefficient: B < |A| at guide row {g}, tendon {i + 1} "
                f"(A {self.A_[g, i]:g}, B {self.B_[g, i]:g}); mu(alpha) = A cos(alpha) + B needs B >= |A|"
            )

    def _hold_saved_geometry(self) -> None:
        """A model saved before the routing wrap and the clearance were fitted ran with its robot's: hold them.

        Such a file has no routing block and a contact block without ``alpha_c`` (a fitted model
        saves its blocks' values); it was calibrated with the hard gate at ``geometry_``'s angles,
        which are what it was fitted with, so it loads and predicts as it did.
        """
        given = compose(self.blocks)
        if any(b.stage == "routing" for b in given):
            return
        geo = self.geometry_
        held = ContactGate(alpha_c=geo.alpha_c, gate="hard", fixed=True)
        self.blocks = tuple(held if isinstance(b, ContactGate) else b for b in given)
        self.blocks += (RoutingWrap(alpha_0=geo.alpha_0, fixed=True),)


def _block_values(saved) -> dict[str, dict[str, float]]:
    """A saved model's fitted block values, each a finite number (else a ConfigError)."""
    if not isinstance(saved, dict) or not all(isinstance(v, dict) for v in saved.values()):
        raise ConfigError("state.block_values must map each block to its parameter values")
    out = {}
    for name, values in saved.items():
        try:
            out[name] = {k: float(v) for k, v in values.items()}
        except (TypeError, ValueError, OverflowError):
            raise ConfigError(f"state.block_values.{name} holds a value that is not a number") from None
        bad = [k for k, v in out[name].items() if not math.isfinite(v)]
        if bad:
            raise ConfigError(f"state.block_values.{name}.{bad[0]} is not finite")
    # A block's value missing from the file takes the block's own (a model saved before that
    # value was fitted predicts as it did); only what is there must be a finite number.
    return out


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
