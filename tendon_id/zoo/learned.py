"""PG-CHTC in the zoo: the paper's physics-guided cascade behind ``fit``/``predict`` (:doc:`/guide/pgchtc`)."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import asdict

import numpy as np
import torch

from learners.cascade import Cascade, CascadeInputs
from learners.loss import LossWeights
from learners.presets import UnitConfig
from learners.presets import preset as get_preset
from learners.training import Sequences, TrainingError, fit_feature_norm, train_two_stage
from tendon_id.data import Recording
from tendon_id.errors import ConfigError, TendonIdError
from tendon_id.geometry import RobotGeometry, sin_q
from tendon_id.progress import epoch_progress
from tendon_id.zoo.features import check_tendon_count, padded_unit_inputs
from tendon_id.zoo.guard import GuardedCascade
from tendon_id.zoo.inputs import TransmissionInputs, as_recordings
from tendon_id.zoo.neural import load_weights, resolve_device, weights_array
from tendon_id.zoo.registry import make
from tendon_id.zoo.stream import PGCHTCStream


class PGCHTC(GuardedCascade):
    """The physics-guided cable-hole transmission cascade (paper Section III).

    Parameters
    ----------
    preset : {"fast", "paper", "tiny"}
        Sizes and schedule (:mod:`learners.presets`). ``paper`` is the paper's.
    physics_reg : bool
        Capstan prior and smoothness terms (False: the "w/o Physics Regularizer" ablation,
        ``lambda = lambda_s = 0``).
    temporal_residual : bool
        Causal Transformer residual ``g_phi`` (False: the "w/o Temporal Residual" ablation).
    tied : bool
        Share one unit across guides (the paper) or give each guide its own.
    lam, lam_s, eta_w : float
        Loss weights of Eqs. (11)–(15) (paper: 1.0, 0.1, 2.0).
    prior : str or dict
        Where the capstan prior's ``(A_i, B_i)`` (Eq. (9)) come from: a zoo model name
        calibrated on the training split (default ``"capstan-nonsmooth"``, the best physics
        baseline, as the paper takes its prior from its calibrated baseline), or an explicit
        ``{"A": [n numbers], "B": [n numbers]}`` (one per tendon of a set), optionally with the routing
        wrap ``"alpha_0"`` (default 0) and the clearance ``"alpha_c"`` [rad] (default: from the robot's
        measured sizes).
    window : int, optional
        History window ``h`` [frames]; default the preset's (20).
    val_fraction : float
        Share of trajectories held out for early stopping.
    device : str
        ``"auto"`` (CUDA when present), ``"cpu"`` or ``"cuda"``.
    seed : int
        Seeds the split, the weights and the batches.
    robot : dict, optional
        Robot description; default from the data's metadata.
    progress : bool, optional
        Progress bars (default: on a terminal).
    fallback : {False, True, "per-kind"}
        When the trained cascade predicts the validation trajectories worse than its own
        calibrated prior model (the guard, :mod:`tendon_id.zoo.guard`), predict with that
        prior instead: True where the pooled validation is worse; ``"per-kind"`` also, when
        the pool passes, on the kinds of motion (steps, scans, paths) that are worse.
        Default False: the paper's behaviour, the cascade, with a warning.

    Attributes
    ----------
    cascade_ : learners.Cascade
    n_tendons_ : int
        Tendons per set ``n`` of the training data: the units' widths follow it (paper Eq. (7)).
    prior_A_, prior_B_ : ndarray, shape (n,)
        The capstan prior's law (Eq. (9)), calibrated on the training split.
    history_ : dict
        Per-epoch train and validation losses of both stages.
    prior_model_ : CapstanModel
        The calibrated prior model (the one ``prior`` names, or capstan-nonsmooth with the given law).
    alpha_0_ : float
        The routing wrap of the unit inputs' wrap [rad]: the prior's fitted one (0 without a prior).
    guard_ : dict
        Validation terminal RMSE of the cascade and of its prior [N], their ratio, ``worse``
        and ``fallback``, pooled and per kind of motion (:func:`tendon_id.zoo.guard.guard_report`).
    """

    name = "pg-chtc"

    def __init__(
        self,
        preset: str = "fast",
        physics_reg: bool = True,
        temporal_residual: bool = True,
        tied: bool = True,
        lam: float = 1.0,
        lam_s: float = 0.1,
        eta_w: float = 2.0,
        prior: str | dict = "capstan-nonsmooth",
        window: int | None = None,
        val_fraction: float = 0.3,
        device: str = "auto",
        seed: int = 0,
        robot: dict | None = None,
        progress: bool | None = None,
        fallback: bool | str = False,
    ):
        self.preset = preset
        self.physics_reg = physics_reg
        self.temporal_residual = temporal_residual
        self.tied = tied
        self.lam = lam
        self.lam_s = lam_s
        self.eta_w = eta_w
        self.prior = prior
        self.window = window
        self.val_fraction = val_fraction
        self.device = device
        self.seed = seed
        self.robot = robot
        self.progress = progress
        self.fallback = fallback

    # ---- configuration --------------------------------------------------------------
    def _unit_config(self) -> UnitConfig:
        try:
            overrides = {"temporal_residual": bool(self.temporal_residual)}
            if self.window is not None:
                overrides["window"] = int(self.window)
            return get_preset(self.preset, **overrides).unit
        except ValueError as exc:
            raise ConfigError(str(exc)) from None

    def _weights(self) -> LossWeights:
        return LossWeights(self.lam if self.physics_reg else 0.0, self.lam_s if self.physics_reg else 0.0, self.eta_w)

    # ---- data ---------------------------------------------------------------------------
    def _inputs(self, recs: list[Recording], geometry) -> TransmissionInputs:
        return TransmissionInputs.from_recordings(recs, geometry)

    def _sequences(self, recs: list[Recording], chunk: int, A: np.ndarray, B: np.ndarray, device) -> Sequences:
        inp = self._inputs(recs, self.geometry_)
        pieces = [(s, min(s + chunk, e)) for s0, e in inp.trajectory_bounds for s in range(s0, e, chunk)]
        n = inp.n_modules
        arr = padded_unit_inputs(inp, pieces, self.alpha_0_, modules=slice(n - 1, n))  # the input: set N's tension
        c, L = arr["alpha"].shape[:2]
        alpha = inp.wrap_at(self.alpha_0_)
        phys = -(A * np.cos(alpha)[..., None] + B) * alpha[..., None]  # ln r_phys, Eq. (9)
        n_t = inp.actuator.shape[-1]
        arr.update(
            since=np.zeros((c, L), dtype=np.int64),
            term=np.zeros((c, L, n_t)),
            phys=np.zeros((c, L, n - 1, n_t)),
            mask=np.zeros((c, L), dtype=bool),
        )
        since_all = np.rint(inp.since_start / inp.dt).astype(np.int64)
        for ci, (s, e) in enumerate(pieces):
            m = e - s
            arr["since"][ci, :m] = np.minimum(since_all[s:e], np.arange(m))  # no history before the chunk
            arr["term"][ci, :m] = np.log(inp.terminal[s:e])
            arr["phys"][ci, :m] = phys[s:e]
            arr["mask"][ci, :m] = True
            arr["term"][ci, m:] = arr["term"][ci, m - 1]  # padding: finite values, masked out of the loss
        f32 = lambda a: torch.as_tensor(a, dtype=torch.float32, device=device)  # noqa: E731
        return Sequences(
            CascadeInputs(
                f32(arr["sin_q"]), f32(arr["alpha"]), f32(arr["act"]), torch.as_tensor(arr["since"], device=device)
            ),
            f32(arr["term"]),
            f32(arr["phys"]),
            torch.as_tensor(arr["mask"], device=device),
        )

    @property
    def alpha_0_(self) -> float:
        """The routing wrap of the unit inputs' wrap [rad]: the calibrated prior's (0 for a model saved without one)."""
        prior = getattr(self, "prior_model_", None)
        return 0.0 if prior is None else prior.alpha_0_

    # ---- estimator API -----------------------------------------------------------------
    def fit(self, data: Recording | Sequence[Recording]) -> PGCHTC:
        """Calibrate the capstan prior, then train the cascade on terminal-only labels (two stages)."""
        self.check_settings()
        cfg = self._unit_config()
        recs = [r.fitting_view() for r in as_recordings(data)]
        for r in recs:
            r.check_history_window(cfg.window)
        allrec = Recording.concat(recs) if len(recs) > 1 else recs[0]
        if len(allrec.trajectories) < 2:
            raise ConfigError("PG-CHTC needs at least two trajectories (one to train on, one to validate)")
        train, val = allrec.split((1.0 - self.val_fraction, self.val_fraction), seed=self.seed)
        torch.manual_seed(self.seed)
        device = resolve_device(self.device, float64=True)
        self.geometry_ = TransmissionInputs.from_recordings([train], self.robot).geometry
        self.n_modules_ = allrec.n_modules
        n_t = allrec.n_tendons
        if isinstance(self.prior, dict):
            self.prior_A_, self.prior_B_ = (self._prior_law(k, n_t) for k in ("A", "B"))
            # No fitted geometry: the routing wrap given, else 0; the clearance given, else the robot's sizes'.
            given = {"routing": {"alpha_0": float(self.prior.get("alpha_0", 0.0))}}
            if "alpha_c" in self.prior:
                given["contact"] = {"alpha_c": float(self.prior["alpha_c"])}
            law = make("capstan-nonsmooth", robot=self.geometry_).fitted_with(
                self.prior_A_, self.prior_B_, self.geometry_, self.n_modules_, given
            )
        else:  # Eq. (9) with the law of a calibrated capstan model (tied)
            law = make(self.prior, robot=self.geometry_, tying="tied", seed=self.seed).fit(train)
            self.prior_A_, self.prior_B_ = law.A_[0].copy(), law.B_[0].copy()
        self.prior_model_ = law
        tr_inp = self._inputs([train], self.geometry_)
        cascade = Cascade(self.n_modules_ - 1, cfg, tied=bool(self.tied), n_tendons=n_t)
        fit_feature_norm(
            cascade,
            sin_q(tr_inp.angles),
            tr_inp.wrap_at(self.alpha_0_),
            np.concatenate([tr_inp.actuator.reshape(-1, n_t), tr_inp.terminal]),
        )
        cascade.to(device)
        tc = get_preset(self.preset).train
        seq_tr = self._sequences([train], tc.chunk2, self.prior_A_, self.prior_B_, device)
        seq_va = self._sequences([val], tc.chunk2, self.prior_A_, self.prior_B_, device)
        try:
            hist = train_two_stage(
                cascade, seq_tr, seq_va, tc, self._weights(), seed=self.seed, progress=epoch_progress(self.progress)
            )
        except TrainingError as exc:
            raise TendonIdError(str(exc)) from None
        self.cascade_ = cascade.cpu().eval()
        self.history_ = {
            "stage1": hist.stage1,
            "stage2": hist.stage2,
            "best_val1": hist.best_val1,
            "best_val2": hist.best_val2,
        }
        self._guard(val)
        return self

    def _prior_law(self, key: str, n_tendons: int) -> np.ndarray:
        """``prior[key]`` (``"A"`` or ``"B"``) as one number per tendon, else a ConfigError that says how many."""
        law = np.asarray(self.prior[key], dtype=float).ravel()
        if law.shape != (n_tendons,):
            raise ConfigError(
                f"{key} needs {n_tendons} numbers (one per tendon of a set), got {law.size}", param="prior"
            )
        return law

    @property
    def n_tendons_(self) -> int:
        """Tendons per set the model was fitted on (3 for a model saved before the count was stored)."""
        self.check_fitted()
        return int(self.cascade_.n_tendons)

    def cascade_inputs(self, recs: list[Recording]) -> tuple[CascadeInputs, list[tuple[int, int]], TransmissionInputs]:
        """The cascade's batch input, one padded row per trajectory, with the trajectories' bounds and inputs."""
        inp = self._inputs(recs, self.geometry_)
        bounds = inp.trajectory_bounds
        a = padded_unit_inputs(inp, bounds, self.alpha_0_)
        since = np.zeros(a["alpha"].shape[:2], dtype=np.int64)
        for bi, (s, e) in enumerate(bounds):
            since[bi, : e - s] = np.arange(e - s)
        # float64: the cascade normalises its inputs and sums its chain in float64 (learners.cascade),
        # the units in theirs.
        f64 = lambda x: torch.as_tensor(x, dtype=torch.float64)  # noqa: E731
        return CascadeInputs(f64(a["sin_q"]), f64(a["alpha"]), f64(a["act"]), torch.as_tensor(since)), bounds, inp

    def _check(self, data) -> list[Recording]:
        recs = self._check_data(data)
        check_tendon_count(recs, self.n_tendons_, self.name)
        for r in recs:
            r.check_history_window(self.history_frames)
        return recs

    @property
    def history_frames(self) -> int:
        self.check_fitted()
        return int(self.cascade_.cfg.window)

    def predict_chain(self, data: Recording | Sequence[Recording]) -> np.ndarray:
        """Every ``T[k, j, i]`` [N], shape (T, N, N, n), NaN where ``k > j``.

        Batched over trajectories, time and sets.
        """
        recs = self._check(data)
        prior = self._prior_chain(recs)
        if prior is not None:
            return prior
        cin, bounds, inp = self.cascade_inputs(recs)
        n, n_t = inp.n_modules, self.n_tendons_
        with torch.no_grad():
            _, log_ratio = self.cascade_(cin, torch.arange(n))
        log_ratio = log_ratio.double().numpy()  # (B, L, N-1, N, n)
        chain = np.full((inp.n_frames, n, n, n_t), np.nan)
        for bi, (s, e) in enumerate(bounds):
            m = e - s
            cum = np.cumsum(log_ratio[bi, :m], axis=1)  # through guides 1..k
            log_chain = np.concatenate([np.zeros((m, 1, n, n_t)), cum], axis=1) + np.log(inp.actuator[s:e])[:, None]
            chain[s:e] = np.exp(log_chain)
        chain[:, 0] = inp.actuator
        chain[:, np.arange(n)[:, None] > np.arange(n)[None, :]] = np.nan
        return self._prior_where_worse(recs, chain)

    def streamer(
        self, engine: str = "auto", threads: int | str | None = None, weights: str = "float32"
    ) -> PGCHTCStream:
        """A frame-by-frame estimator with causal caches (O(1) per frame).

        See :class:`PGCHTCStream` for ``engine``, ``threads`` and ``weights``.
        """
        self.check_fitted()
        if self.uses_prior_:
            raise ConfigError(
                "this pg-chtc model predicts with its prior capstan-nonsmooth (the guard found the cascade worse and "
                "fallback=True), which PG-CHTC's engines do not stream; stream pg-chtc-ns instead, whose correction "
                "is kept only where it helps"
            )
        self._warn_stream_kinds()
        return PGCHTCStream(self, engine, threads, weights)

    # ---- persistence ----------------------------------------------------------------------
    def _state(self):
        state = {
            "n_modules": self.n_modules_,
            "geometry": self.geometry_.to_dict(),
            "unit": asdict(self.cascade_.cfg),
            "tied": bool(self.cascade_.tied),
            "prior_A": self.prior_A_.tolist(),
            "prior_B": self.prior_B_.tolist(),
            "history": self.history_,
        }
        if self.n_tendons_ != 3:  # left out for the paper's 3, so that such a model's files are as before the count
            state["n_tendons"] = self.n_tendons_
        prior_state, prior_arrays = self._prior_state()
        return {**state, **prior_state}, {**weights_array(self.cascade_), **prior_arrays}

    def _restore(self, state, arrays):
        self.n_modules_ = int(state["n_modules"])
        self.geometry_ = RobotGeometry.from_dict(state["geometry"])
        unit = dict(state["unit"])
        unit["hidden"] = tuple(unit["hidden"])
        n_t = int(state.get("n_tendons", 3))  # a model saved before the count: the paper's 3
        self.cascade_ = load_weights(
            lambda: Cascade(self.n_modules_ - 1, UnitConfig(**unit), tied=bool(state["tied"]), n_tendons=n_t), arrays
        )
        self.prior_A_, self.prior_B_ = np.asarray(state["prior_A"]), np.asarray(state["prior_B"])
        self.history_ = state.get("history", {})
        self._restore_prior(state, arrays)
