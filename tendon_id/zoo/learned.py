"""PG-CHTC in the zoo: the paper's physics-guided cascade behind ``fit``/``predict`` (DESIGN §9)."""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from dataclasses import asdict

import numpy as np
import torch

from learners.cascade import Cascade, CascadeInputs, StreamingCascade
from learners.loss import LossWeights
from learners.presets import UnitConfig, preset as get_preset
from learners.streaming_native import KernelUnavailable, NativeStreamingCascade, disabled as native_disabled
from learners.training import Sequences, TrainingError, fit_feature_norm, train_two_stage
from tendon_id.data import Recording
from tendon_id.errors import ConfigError, TendonIdError
from tendon_id.progress import progress_bar
from tendon_id.geometry import RobotGeometry, backbone_wrap
from tendon_id.zoo.base import TransmissionModel
from tendon_id.zoo.inputs import TransmissionInputs, as_recordings


def resolve_device(device: str, *, float64: bool = False) -> torch.device:
    """``"auto"``: CUDA when present, else CPU.

    Raises
    ------
    ConfigError
        For a device string torch does not know, or, with ``float64=True`` (PG-CHTC normalises
        its inputs and sums its chain in float64), a device without float64 such as Apple's MPS.
    """
    if device == "auto":
        return torch.device("cuda" if torch.cuda.is_available() else "cpu")
    try:
        dev = torch.device(device)
    except (RuntimeError, TypeError):
        raise ConfigError(f"device must be 'auto', 'cpu' or 'cuda[:i]'; got {device!r}") from None
    if float64 and dev.type not in ("cpu", "cuda"):
        raise ConfigError(f"PG-CHTC runs on 'cpu' or 'cuda' (it needs float64 for its inputs and chain, which MPS lacks); got {device!r}")
    return dev


def _sin_q(angles: np.ndarray) -> np.ndarray:
    """``sin(q_k)`` with ``q_k = (theta_k, theta_{k+1})`` (paper Eq. (2)): angles (..., N, 2) in, (..., N-1, 4) out."""
    s = np.sin(angles)
    return np.concatenate([s[..., :-1, :], s[..., 1:, :]], axis=-1)


def _tqdm_epochs(enable: bool | None):
    """Epoch-bar factory for the training loop (a bar on a terminal, nothing elsewhere)."""
    return lambda it, desc: progress_bar(it, desc=desc, enable=enable)


class PGCHTC(TransmissionModel):
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
        ``{"A": [3 numbers], "B": [3 numbers]}``.
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

    Attributes
    ----------
    cascade_ : learners.Cascade
    prior_A_, prior_B_ : ndarray, shape (3,)
        The capstan prior's law (Eq. (9)), calibrated on the training split.
    history_ : dict
        Per-epoch train and validation losses of both stages.
    """

    name = "pg-chtc"

    def __init__(self, preset: str = "fast", physics_reg: bool = True, temporal_residual: bool = True, tied: bool = True,
                 lam: float = 1.0, lam_s: float = 0.1, eta_w: float = 2.0, prior: str | dict = "capstan-nonsmooth",
                 window: int | None = None, val_fraction: float = 0.3,
                 device: str = "auto", seed: int = 0, robot: dict | None = None, progress: bool | None = None):
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
        bounds = inp.trajectory_bounds
        pieces = [(s, min(s + chunk, e)) for s0, e in bounds for s in range(s0, e, chunk)]
        L = max(e - s for s, e in pieces)
        n, c = inp.n_modules, len(pieces)
        sin_q, alpha = _sin_q(inp.angles), inp.wrap
        phys = -(A * np.cos(alpha)[..., None] + B) * alpha[..., None]  # ln r_phys, Eq. (9)
        arr = {"sin_q": np.zeros((c, L, n - 1, 4)), "alpha": np.zeros((c, L, n - 1)), "act": np.zeros((c, L, 1, 3)),
               "since": np.zeros((c, L), dtype=np.int64), "term": np.zeros((c, L, 3)), "phys": np.zeros((c, L, n - 1, 3)),
               "mask": np.zeros((c, L), dtype=bool)}
        since_all = np.rint(inp.since_start / inp.dt).astype(np.int64)
        for ci, (s, e) in enumerate(pieces):
            m = e - s
            arr["sin_q"][ci, :m] = sin_q[s:e]
            arr["alpha"][ci, :m] = alpha[s:e]
            arr["act"][ci, :m, 0] = np.log(inp.actuator[s:e, n - 1])
            arr["since"][ci, :m] = np.minimum(since_all[s:e], np.arange(m))  # no history before the chunk
            arr["term"][ci, :m] = np.log(inp.terminal[s:e])
            arr["phys"][ci, :m] = phys[s:e]
            arr["mask"][ci, :m] = True
            arr["act"][ci, m:, 0] = arr["act"][ci, m - 1, 0]  # padding: finite values, masked out of the loss
            arr["term"][ci, m:] = arr["term"][ci, m - 1]
        f32 = lambda a: torch.as_tensor(a, dtype=torch.float32, device=device)  # noqa: E731
        return Sequences(CascadeInputs(f32(arr["sin_q"]), f32(arr["alpha"]), f32(arr["act"]),
                                       torch.as_tensor(arr["since"], device=device)),
                         f32(arr["term"]), f32(arr["phys"]), torch.as_tensor(arr["mask"], device=device))

    # ---- estimator API -----------------------------------------------------------------
    def fit(self, data: Recording | Sequence[Recording]) -> PGCHTC:
        """Calibrate the capstan prior, then train the cascade on terminal-only labels (two stages)."""
        from tendon_id.zoo.registry import make

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
        if isinstance(self.prior, dict):
            self.prior_A_ = np.asarray(self.prior["A"], dtype=float).reshape(3)
            self.prior_B_ = np.asarray(self.prior["B"], dtype=float).reshape(3)
        else:  # Eq. (9) with the law of a calibrated capstan model (tied)
            law = make(self.prior, robot=self.geometry_, tying="tied", seed=self.seed).fit(train)
            self.prior_A_, self.prior_B_ = law.A_[0].copy(), law.B_[0].copy()
        tr_inp = self._inputs([train], self.geometry_)
        cascade = Cascade(self.n_modules_ - 1, cfg, tied=bool(self.tied))
        fit_feature_norm(cascade, _sin_q(tr_inp.angles), tr_inp.wrap, np.concatenate([tr_inp.actuator.reshape(-1, 3), tr_inp.terminal]))
        cascade.to(device)
        tc = get_preset(self.preset).train
        seq_tr = self._sequences([train], tc.chunk2, self.prior_A_, self.prior_B_, device)
        seq_va = self._sequences([val], tc.chunk2, self.prior_A_, self.prior_B_, device)
        try:
            hist = train_two_stage(cascade, seq_tr, seq_va, tc, self._weights(), seed=self.seed, progress=_tqdm_epochs(self.progress))
        except TrainingError as exc:
            raise TendonIdError(str(exc)) from None
        self.cascade_ = cascade.cpu().eval()
        self.history_ = {"stage1": hist.stage1, "stage2": hist.stage2, "best_val1": hist.best_val1, "best_val2": hist.best_val2}
        return self

    def _cascade_inputs(self, recs: list[Recording]) -> tuple[CascadeInputs, list[tuple[int, int]], TransmissionInputs]:
        inp = self._inputs(recs, self.geometry_)
        bounds = inp.trajectory_bounds
        L = max(e - s for s, e in bounds)
        n, b = inp.n_modules, len(bounds)
        sin_q, alpha = _sin_q(inp.angles), inp.wrap
        a = {"sin_q": np.zeros((b, L, n - 1, 4)), "alpha": np.zeros((b, L, n - 1)), "act": np.zeros((b, L, n, 3)),
             "since": np.zeros((b, L), dtype=np.int64)}
        for bi, (s, e) in enumerate(bounds):
            m = e - s
            a["sin_q"][bi, :m], a["alpha"][bi, :m] = sin_q[s:e], alpha[s:e]
            a["act"][bi, :m] = np.log(inp.actuator[s:e])
            a["act"][bi, m:] = a["act"][bi, m - 1]
            a["since"][bi, :m] = np.arange(m)
        # float64: the cascade normalises its inputs and sums its chain in float64 (learners.cascade), the units in theirs.
        f64 = lambda x: torch.as_tensor(x, dtype=torch.float64)  # noqa: E731
        return CascadeInputs(f64(a["sin_q"]), f64(a["alpha"]), f64(a["act"]), torch.as_tensor(a["since"])), bounds, inp

    def _check(self, data) -> list[Recording]:
        recs = self._check_data(data)
        for r in recs:
            r.check_history_window(self.cascade_.cfg.window)
        return recs

    def predict_chain(self, data: Recording | Sequence[Recording]) -> np.ndarray:
        """Every ``T[k, j, i]`` [N], shape (T, N, N, 3), NaN where ``k > j``; batched over trajectories, time and sets."""
        recs = self._check(data)
        cin, bounds, inp = self._cascade_inputs(recs)
        n = inp.n_modules
        with torch.no_grad():
            _, log_ratio = self.cascade_(cin, torch.arange(n))
        log_ratio = log_ratio.double().numpy()  # (B, L, N-1, N, 3)
        chain = np.full((inp.n_frames, n, n, 3), np.nan)
        for bi, (s, e) in enumerate(bounds):
            m = e - s
            cum = np.cumsum(log_ratio[bi, :m], axis=1)  # through guides 1..k
            log_chain = np.concatenate([np.zeros((m, 1, n, 3)), cum], axis=1) + np.log(inp.actuator[s:e])[:, None]
            chain[s:e] = np.exp(log_chain)
        chain[:, 0] = inp.actuator
        chain[:, np.arange(n)[:, None] > np.arange(n)[None, :]] = np.nan
        return chain

    def streamer(self, engine: str = "auto", threads: int | None = None) -> PGCHTCStream:
        """A frame-by-frame estimator with causal caches (O(1) per frame); see :class:`PGCHTCStream` for ``engine`` and ``threads``."""
        self._check_fitted()
        return PGCHTCStream(self, engine, threads)

    # ---- persistence ----------------------------------------------------------------------
    def _state(self):
        from safetensors.numpy import save

        weights = {k: v.detach().cpu().numpy() for k, v in self.cascade_.state_dict().items()}
        state = {"n_modules": self.n_modules_, "geometry": self.geometry_.to_dict(), "unit": asdict(self.cascade_.cfg),
                 "tied": bool(self.cascade_.tied), "prior_A": self.prior_A_.tolist(), "prior_B": self.prior_B_.tolist(),
                 "history": self.history_}
        return state, {"weights_safetensors": np.frombuffer(save(weights), dtype=np.uint8)}

    def _restore(self, state, arrays):
        from safetensors.numpy import load

        self.n_modules_ = int(state["n_modules"])
        self.geometry_ = RobotGeometry.from_dict(state["geometry"])
        unit = dict(state["unit"])
        unit["hidden"] = tuple(unit["hidden"])
        cascade = Cascade(self.n_modules_ - 1, UnitConfig(**unit), tied=bool(state["tied"]))
        weights = load(arrays["weights_safetensors"].tobytes())
        cascade.load_state_dict({k: torch.as_tensor(v) for k, v in weights.items()})
        self.cascade_ = cascade.eval()
        self.prior_A_, self.prior_B_ = np.asarray(state["prior_A"]), np.asarray(state["prior_B"])
        self.history_ = state.get("history", {})


STREAM_ENGINES = ("auto", "native", "torch")


class PGCHTCStream:
    """Streaming PG-CHTC: ``step(frame) -> (N, 3)`` joint-side estimates [N] (paper Algorithm 1).

    Parameters
    ----------
    model : PGCHTC
        A fitted model.
    engine : {"auto", "native", "torch"}
        ``"native"`` runs each frame in a small C kernel compiled once per machine
        (:mod:`learners.streaming_native`); ``"torch"`` in a traced TorchScript graph
        (:class:`~learners.cascade.StreamingCascade`).  Both compute the same frame as batch
        inference: units in float32, inputs and chain in float64.  ``"auto"`` (default) takes the kernel where it builds and the model is a
        float32 CPU model, and the torch engine otherwise (with a warning if the kernel
        failed to build).
    threads : {1, 2}, optional
        Native engine only: 2 computes ``g_phi`` on a helper thread beside ``f_theta`` within
        each frame, with the same result to the bit.  Default: 2 where the model has a temporal
        residual and the process may use two CPUs, else 1.

    Attributes
    ----------
    engine_name : str
        The engine in use, ``"native"`` or ``"torch"``.
    """

    def __init__(self, model: PGCHTC, engine: str = "auto", threads: int | None = None):
        if engine not in STREAM_ENGINES:
            raise ConfigError(f"engine must be one of {', '.join(STREAM_ENGINES)}; got {engine!r}")
        if threads not in (None, 1, 2):
            raise ConfigError(f"threads must be 1 or 2; got {threads!r}")
        self.model = model
        self.alpha0 = model.geometry_.alpha_0
        self.engine_name = "torch"
        if engine in ("auto", "native"):
            try:
                self.engine = NativeStreamingCascade(model.cascade_, model.n_modules_, threads)
                self.engine_name = "native"
            except KernelUnavailable as exc:
                if engine == "native":
                    raise TendonIdError(f"the native streaming engine is unavailable: {exc}") from None
                if not native_disabled():  # switched off on purpose: no warning
                    warnings.warn(f"streaming on the slower torch engine: {exc}", RuntimeWarning, stacklevel=3)
        if self.engine_name == "torch":
            self.engine = StreamingCascade(model.cascade_, model.n_modules_)

    def reset(self) -> None:
        """Start a new trajectory."""
        self.engine.reset()

    def step(self, angles: np.ndarray, actuator: np.ndarray) -> np.ndarray:
        """One frame: joint angles (N, 2) [rad] and actuator-side tensions (N, 3) [N] in; ``T_hat[j, j]`` (N, 3) out."""
        sin_q, alpha, log_act = _sin_q(angles), backbone_wrap(angles, self.alpha0), np.log(actuator)
        if self.engine_name == "native":
            out = self.engine.step(sin_q, alpha, log_act)
        else:
            out = self._torch_step(sin_q, alpha, log_act)
        est = np.exp(out)
        est[0] = actuator[0]
        return est

    def _torch_step(self, sin_q: np.ndarray, alpha: np.ndarray, log_act: np.ndarray) -> np.ndarray:
        """The torch engine on one thread: a frame is hundreds of small operations, for which waking a
        second OpenMP thread costs more than it saves (measured for the paper preset on 2 cores: 5.0
        against 5.0 ms traced, 7.2 against 7.1 ms eager; one thread keeps other work free)."""
        threads = torch.get_num_threads()
        if threads != 1:
            torch.set_num_threads(1)
        try:
            return self.engine.step(*map(torch.as_tensor, (sin_q, alpha, log_act))).numpy()
        finally:
            if threads != 1:
                torch.set_num_threads(threads)
