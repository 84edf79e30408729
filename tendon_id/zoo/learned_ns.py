"""PG-CHTC-NS in the zoo: the ratio cascade whose prior is the calibrated nonsmooth capstan and whose memory
is the prior's hysteresis state (:mod:`learners.correction`).

The paper's unit has a contact-agnostic prior and a 2 s window of memory, so where stick/slip
dominates it cannot tell a stuck tendon from a slipping one.  This variant keeps the paper's
multiplicative cascade and its loss (Eqs. (11)–(15)), but

* its prior is capstan-nonsmooth calibrated on the training trajectories: contact gate and play
  operator, with the play operator's state carried along the chain and through time;
* each guide's ratio is the prior's times a bounded learned correction, read from the paper's unit
  inputs (Eq. (7)) plus the prior's state at that guide (:mod:`friction_models.play_state`);
* the correction starts at zero and is kept only where it lowers the validation loss.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import asdict

import numpy as np
import torch

from friction_models.play_state import N_STATE, play_state
from learners.correction import CorrectedCascade, CorrectionConfig, CorrectionInputs, train_correction
from learners.loop import LoopSchedule, TrainingError
from learners.loss import LossWeights
from learners.presets import preset as get_preset
from learners.training import fit_feature_norm
from tendon_id.data import Recording
from tendon_id.errors import ConfigError, TendonIdError
from tendon_id.geometry import RobotGeometry, sin_q
from tendon_id.progress import epoch_progress
from tendon_id.zoo.features import check_tendon_count
from tendon_id.zoo.guard import GuardedCascade
from tendon_id.zoo.inputs import TransmissionInputs, as_recordings
from tendon_id.zoo.neural import load_weights, resolve_device, weights_array
from tendon_id.zoo.registry import make

#: The prior: the paper's physics baseline (contact gate and stick/slip hysteresis).
PRIOR = "capstan-nonsmooth"


def prior_terms(prior, inputs: TransmissionInputs, sets: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The prior's log ratio and play-operator state at every guide, for ``sets``.

    Parameters
    ----------
    prior : CapstanModel
        A fitted capstan-nonsmooth model.
    inputs : TransmissionInputs
    sets : ndarray of int
        0-based sets to propagate.

    Returns
    -------
    log_ratio : ndarray, shape (T, K, S, n)
        ``ln r_prior`` [-], 0 where a set does not pass the guide; ``n`` tendons per set.
    state : ndarray of float32, shape (T, K, S, n, 4)
        :func:`friction_models.play_state.play_state` of each guide's play operator, 0 off the path.
    """
    values = prior.block_params_
    chain = prior.propagate(inputs, prior.A_, prior.B_, values, sets=sets)  # (T, N, S, n), NaN off the path
    phi = prior.exponent(inputs, prior.A_, prior.B_, values)  # (T, K, N|1, n)
    t, n, s, n_t = chain.shape[0], chain.shape[1], len(sets), chain.shape[-1]
    log_ratio = np.zeros((t, n - 1, s, n_t))
    state = np.zeros((t, n - 1, s, n_t, N_STATE), dtype=np.float32)
    for g in range(n - 1):
        active = sets > g
        if not active.any():
            break
        x, y = chain[:, g, active], chain[:, g + 1, active]
        ph = phi[:, g][:, sets[active]] if phi.shape[2] > 1 else phi[:, g]
        log_ratio[:, g, active] = y - x
        state[:, g, active] = play_state(y, x - ph, x + ph, inputs.reset, inputs.dt)
    return log_ratio, state


class PGCHTCNS(GuardedCascade):
    """The nonsmooth-prior cascade: capstan-nonsmooth times a bounded correction that reads the hysteresis state.

    Parameters
    ----------
    preset : {"fast", "paper", "tiny"}
        Width of the correction's MLP and the training schedule (stage 1's of
        :mod:`learners.presets`).
    correction : bool
        Learn the correction (False: the "w/o correction" ablation, which is capstan-nonsmooth
        calibrated on all the data).
    state_inputs : bool
        Feed the prior's hysteresis state to the correction (False: the "w/o state inputs" ablation).
    bound : float
        Largest correction of one guide's log ratio [-].
    tied : bool
        One correction unit for every guide, or one per guide.
    lam, lam_s, eta_w : float
        Loss weights of Eqs. (11)–(15) (paper: 1.0, 0.1, 2.0); the prior term is measured
        against the nonsmooth prior.
    prior_warmup_s : float
        The prior's ``warmup_s`` [s]: seconds at the start of each trajectory left out of its
        calibration (0: capstan-nonsmooth as the baselines calibrate it).
    val_fraction : float
        Share of trajectories held out for early stopping and the guard.
    device : str
        ``"auto"``, ``"cpu"`` or ``"cuda"``.
    seed : int
        Seeds the split, the weights and the batches.
    robot : dict, optional
        Robot description; default from the data's metadata.
    progress : bool, optional
        Progress bars (default: on a terminal).
    fallback : {False, True, "per-kind"}
        Predict with the prior when the guard finds the cascade worse on validation: True
        where the pool is worse, ``"per-kind"`` also on the kinds of motion that are worse
        (:mod:`tendon_id.zoo.guard`).

    Attributes
    ----------
    cascade_ : learners.correction.CorrectedCascade or None
        None without correction.
    n_tendons_ : int
        Tendons per set ``n`` of the training data: the correction's widths follow it.
    prior_model_ : CapstanModel
        The calibrated nonsmooth capstan.
    alpha_0_ : float
        The routing wrap of the unit inputs' wrap [rad]: the prior's fitted one.
    guard_ : dict
        Validation terminal RMSE of the cascade and of its prior [N], pooled and per kind of
        motion (:mod:`tendon_id.zoo.guard`).
    history_ : dict
        Per-epoch losses of the correction's training.
    dt_ : float
        Sample period of the training data [s] (the state's clock when streaming).
    """

    name = "pg-chtc-ns"

    def __init__(
        self,
        preset: str = "fast",
        correction: bool = True,
        state_inputs: bool = True,
        bound: float = 0.5,
        tied: bool = True,
        lam: float = 1.0,
        lam_s: float = 0.1,
        eta_w: float = 2.0,
        prior_warmup_s: float = 0.0,
        val_fraction: float = 0.3,
        device: str = "auto",
        seed: int = 0,
        robot: dict | None = None,
        progress: bool | None = None,
        fallback: bool | str = False,
    ):
        self.preset = preset
        self.correction = correction
        self.state_inputs = state_inputs
        self.bound = bound
        self.tied = tied
        self.lam = lam
        self.lam_s = lam_s
        self.eta_w = eta_w
        self.prior_warmup_s = prior_warmup_s
        self.val_fraction = val_fraction
        self.device = device
        self.seed = seed
        self.robot = robot
        self.progress = progress
        self.fallback = fallback

    def correction_config(self) -> CorrectionConfig:
        """The correction unit's architecture from the settings (``ConfigError`` for an unknown preset)."""
        try:
            hidden = get_preset(self.preset).unit.hidden
            return CorrectionConfig(hidden=hidden, bound=float(self.bound), state_inputs=bool(self.state_inputs))
        except ValueError as exc:
            raise ConfigError(str(exc)) from None

    def _frames(self, inputs: TransmissionInputs, sets: np.ndarray, device) -> CorrectionInputs:
        log_ratio, state = prior_terms(self.prior_model_, inputs, sets)
        f32 = lambda a: torch.as_tensor(a, dtype=torch.float32, device=device)  # noqa: E731
        f64 = lambda a: torch.as_tensor(a, dtype=torch.float64, device=device)  # noqa: E731
        return CorrectionInputs(
            f64(sin_q(inputs.angles)),
            f64(inputs.wrap_at(self.alpha_0_)),
            f64(np.log(inputs.actuator[:, sets])),
            f64(log_ratio),
            f32(state),
        )

    @property
    def alpha_0_(self) -> float:
        """The routing wrap of the unit inputs' wrap [rad]: the calibrated prior's (0 for a model saved without one)."""
        prior = getattr(self, "prior_model_", None)
        return 0.0 if prior is None else prior.alpha_0_

    # ---- estimator API -----------------------------------------------------------------
    def fit(self, data: Recording | Sequence[Recording]) -> PGCHTCNS:
        """Calibrate capstan-nonsmooth, then train the bounded correction on terminal-only labels."""
        self.check_settings()
        cfg = self.correction_config()
        recs = [r.fitting_view() for r in as_recordings(data)]
        allrec = Recording.concat(recs) if len(recs) > 1 else recs[0]
        self.geometry_ = TransmissionInputs.from_recordings([allrec], self.robot).geometry
        self.dt_ = float(allrec.dt)
        prior = make(PRIOR, robot=self.geometry_, seed=self.seed, warmup_s=float(self.prior_warmup_s))
        self.history_, self.guard_ = {}, {}
        self._n_tendons = allrec.n_tendons
        if not self.correction:  # the ablation: the calibrated physics on all the data
            self.prior_model_ = prior.fit(allrec)
            self.cascade_ = None
            self.n_modules_ = allrec.n_modules
            return self
        if len(allrec.trajectories) < 2:
            raise ConfigError("pg-chtc-ns needs at least two trajectories (one to train on, one to validate)")
        train, val = allrec.split((1.0 - self.val_fraction, self.val_fraction), seed=self.seed)
        torch.manual_seed(self.seed)
        device = resolve_device(self.device, float64=True)
        self.prior_model_ = prior.fit(train)
        n, n_t = allrec.n_modules, self._n_tendons
        cascade = CorrectedCascade(n - 1, cfg, tied=bool(self.tied), n_tendons=n_t)
        tr = TransmissionInputs.from_recordings([train], self.geometry_)
        wrap = tr.wrap_at(self.alpha_0_)
        fit_feature_norm(cascade, sin_q(tr.angles), wrap, np.concatenate([tr.actuator.reshape(-1, n_t), tr.terminal]))
        cascade.to(device)
        terminal = np.array([n - 1])
        label = lambda r: torch.as_tensor(np.log(r.terminal), dtype=torch.float32, device=device)  # noqa: E731
        tc = get_preset(self.preset).train
        try:
            hist = train_correction(
                cascade,
                (self._frames(tr, terminal, device), label(train)),
                (self._frames(TransmissionInputs.from_recordings([val], self.geometry_), terminal, device), label(val)),
                LoopSchedule(tc.lr1, tc.epochs1, tc.patience1, tc.weight_decay),
                LossWeights(self.lam, self.lam_s, self.eta_w),
                batch=tc.batch1,
                seed=self.seed,
                progress=epoch_progress(self.progress),
            )
        except TrainingError as exc:
            raise TendonIdError(str(exc)) from None
        self.cascade_ = cascade.cpu().eval()
        self.n_modules_ = n
        self.history_ = {"epochs": hist.epochs, "best_val": hist.best_val, "best_epoch": hist.best_epoch}
        self._guard(val)
        return self

    @property
    def n_tendons_(self) -> int:
        """Tendons per set the model was fitted on (3 for a model saved before the count was stored, or hand-built)."""
        self.check_fitted()
        return getattr(self, "_n_tendons", 3)

    def predict_chain(self, data: Recording | Sequence[Recording]) -> np.ndarray:
        """Every ``T[k, j, i]`` [N], shape (T, N, N, n), NaN where ``k > j``; batched over time and sets."""
        recs = self._check_data(data)
        check_tendon_count(recs, self.n_tendons_, self.name)
        if self.cascade_ is None or self.uses_prior_:
            return self.prior_model_.predict_chain(recs)
        n = self.n_modules_
        sets = np.arange(n)
        inputs = TransmissionInputs.from_recordings(recs, self.geometry_)
        inp = self._frames(inputs, sets, torch.device("cpu"))
        with torch.no_grad():
            _, log_ratio = self.cascade_(inp, torch.as_tensor(sets))
        cum = np.cumsum(log_ratio.numpy(), axis=1)  # through guides 1..k
        act = inputs.actuator
        chain = np.exp(np.concatenate([np.zeros((len(act), 1, n, act.shape[-1])), cum], axis=1) + np.log(act)[:, None])
        chain[:, 0] = act
        chain[:, np.arange(n)[:, None] > np.arange(n)[None, :]] = np.nan
        return self._prior_where_worse(recs, chain)

    def streamer(self):
        """A frame-by-frame estimator: O(1) per frame (:class:`tendon_id.zoo.streaming_ns.PGCHTCNSStream`)."""
        from tendon_id.zoo.streaming_ns import PGCHTCNSStream

        self.check_fitted()
        self._warn_stream_kinds()
        return PGCHTCNSStream(self)

    # ---- persistence ----------------------------------------------------------------------
    def _state(self):
        state = {
            "n_modules": self.n_modules_,
            "geometry": self.geometry_.to_dict(),
            "dt": self.dt_,
            "history": self.history_,
            "correction": None if self.cascade_ is None else {**asdict(self.cascade_.cfg), "tied": self.cascade_.tied},
        }
        if self.n_tendons_ != 3:  # left out for the paper's 3, so that such a model's files are as before the count
            state["n_tendons"] = self.n_tendons_
        prior_state, prior_arrays = self._prior_state()
        arrays = {} if self.cascade_ is None else weights_array(self.cascade_)
        return {**state, **prior_state}, {**arrays, **prior_arrays}

    def _restore(self, state, arrays):
        self.n_modules_ = int(state["n_modules"])
        self.geometry_ = RobotGeometry.from_dict(state["geometry"])
        self.dt_ = float(state["dt"])
        self._n_tendons = int(state.get("n_tendons", 3))  # a model saved before the count: the paper's 3
        self.history_ = state.get("history", {})
        self._restore_prior(state, arrays)
        cfg = state.get("correction")
        self.cascade_ = None
        if cfg is not None:
            cfg = dict(cfg)
            tied = bool(cfg.pop("tied"))
            cfg["hidden"] = tuple(cfg["hidden"])
            self.cascade_ = load_weights(
                lambda: CorrectedCascade(self.n_modules_ - 1, CorrectionConfig(**cfg), tied, n_tendons=self._n_tendons),
                arrays,
            )
