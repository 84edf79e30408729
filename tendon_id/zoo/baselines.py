"""Learning-only baselines in the zoo: ``mlp``, ``lstm`` and ``transformer`` (paper Table I).

They are black boxes trained, like PG-CHTC, on terminal joint-side labels only, with the
data term of the paper's Eq. (12) in the log domain: each predicts the terminal set's log
ratio, ``ln T_hat[N, N] = ln T[1, N] + net(history)``.  Two forms (``mode``):

``"unit"`` (the default for a single-passage rig, N = 2)
    The unit-level form of the paper's Table I: per frame the same ``5 + n`` inputs as a PG-CHTM
    unit at guide 1 for set 2, ``[sin(q_1) (4), cos(alpha_1), normalised T[1, 2] (n)]``
    (paper Eq. (7), ``n`` tendons per set: 8 inputs for the paper's 3), and the output is the
    passage's ratio.  For N = 2 this is the whole problem.  It is defined for N = 2 only.

``"end-to-end"`` (the default for N > 2)
    The raw causal input history ``X(t) = [all actuator-side tensions (nN), q(t) (2N)]``
    (paper Section III-A) to the terminal joint side ``T[N, N]``.  Trained on terminal
    labels only, a black box has no estimate for the intermediate joints ``2..N-1``:
    ``predict`` returns their actuator side there (the proximal hypothesis, no loss), so
    their joint-level metrics are the proximal model's.  This is the paper's point that
    black boxes cannot resolve intermediate joints from terminal-only labels.

``predict_chain`` is correspondingly the proximal chain (``T[k, j] = T[1, j]`` on every
path, NaN off the path) with ``T[N, N]`` replaced by the estimate.  The output has one log
ratio per tendon: a model fitted on ``n`` tendons per set predicts ``n`` and reads only data
with ``n`` (its ``n_tendons_``).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import asdict
from typing import ClassVar

import numpy as np
import torch

from learners.baselines import (
    BaselineConfig,
    baseline_config,
    build_baseline,
    count_parameters,
    fit_normalisation,
    predict_log_ratio,
    train_baseline,
)
from learners.training import TrainingError
from tendon_id.checks import check_choice
from tendon_id.data import Recording
from tendon_id.errors import ConfigError, TendonIdError
from tendon_id.geometry import RobotGeometry, sin_q
from tendon_id.progress import epoch_progress
from tendon_id.zoo.base import TransmissionModel
from tendon_id.zoo.features import check_tendon_count
from tendon_id.zoo.inputs import TransmissionInputs, as_recordings
from tendon_id.zoo.neural import load_weights, resolve_device, weights_array

MODES = ("auto", "unit", "end-to-end")


class _Baseline(TransmissionModel):
    """A learning-only baseline (see the module docstring).

    Parameters
    ----------
    preset : {"fast", "paper", "tiny"}
        Sizes and schedule (:mod:`learners.baselines`); ``paper`` has about 400 k
        parameters, matched to ``f_theta`` as in the paper's Section IV-B.
    mode : {"auto", "unit", "end-to-end"}
        ``"auto"``: ``"unit"`` for N = 2, ``"end-to-end"`` otherwise.
    window : int
        Frames each attention layer sees (the Transformer only; the MLP reads the current
        frame and the LSTM its whole past, so they ignore it).
    val_fraction : float
        Share of trajectories held out for early stopping; 0 trains on every trajectory
        for the preset's full number of epochs.
    device : str
        ``"auto"`` (CUDA when present), ``"cpu"`` or ``"cuda"``. Prediction runs on the CPU.
    seed : int
        Seeds the split, the weights and the batches.
    robot : dict, optional
        Robot description (for the wrap ``alpha_1`` of the unit form); default from the
        data's metadata.
    progress : bool, optional
        Progress bar over epochs (default: on a terminal).

    Attributes
    ----------
    net_ : learners.baselines.BaselineNet
    mode_ : str
        ``"unit"`` or ``"end-to-end"``.
    n_parameters_ : int
    history_ : dict
        Per-epoch train and validation losses, the best validation loss and its epoch.
    """

    name: ClassVar[str] = "baseline"
    kind: ClassVar[str] = ""

    def __init__(
        self,
        preset: str = "fast",
        mode: str = "auto",
        window: int = 20,
        val_fraction: float = 0.3,
        device: str = "auto",
        seed: int = 0,
        robot: dict | None = None,
        progress: bool | None = None,
    ):
        self.preset = preset
        self.mode = mode
        self.window = window
        self.val_fraction = val_fraction
        self.device = device
        self.seed = seed
        self.robot = robot
        self.progress = progress

    # ---- inputs -----------------------------------------------------------------------------
    def _resolve_mode(self, n_modules: int) -> str:
        check_choice("mode", self.mode, MODES)
        mode = ("unit" if n_modules == 2 else "end-to-end") if self.mode == "auto" else self.mode
        if mode == "unit" and n_modules != 2:
            raise ConfigError(
                f"{self.name}: mode='unit' is the single-passage form (N = 2) but the data has {n_modules} modules; "
                "use mode='end-to-end' (or 'auto')"
            )
        return mode

    @staticmethod
    def _features(inp: TransmissionInputs, mode: str) -> np.ndarray:
        """Per-frame inputs (T, F): ``5 + n`` unit inputs (unit form) or ``X(t)`` (``(n + 2) N``, end to end)."""
        if mode == "unit":  # paper Eq. (7) at guide 1 for set 2 (normalised inside the network)
            # No calibrated prior, so no routing wrap: the joints' part of the wrap (never the metadata's alpha_0).
            wrap = inp.wrap_at(0.0)
            return np.concatenate([sin_q(inp.angles)[:, 0], np.cos(wrap[:, :1]), inp.actuator[:, 1]], axis=1)
        t = inp.n_frames
        return np.concatenate([inp.actuator.reshape(t, -1), inp.angles.reshape(t, -1)], axis=1)

    def _trajectories(self, recs: list[Recording], with_target: bool):
        """Per-trajectory inputs (and target log ratios), plus the stacked inputs."""
        inp = TransmissionInputs.from_recordings(recs, self.geometry_)
        x = self._features(inp, self.mode_)
        bounds = inp.trajectory_bounds
        xs = [x[s:e] for s, e in bounds]
        ys = None
        if with_target:
            y = np.log(inp.terminal) - np.log(inp.actuator[:, -1])  # ln T[N, N] - ln T[1, N]
            ys = [y[s:e] for s, e in bounds]
        return xs, ys, bounds, inp

    @property
    def history_frames(self) -> int:
        return int(self.window) if self.kind == "transformer" else 1

    # ---- estimator API ------------------------------------------------------------------------
    def fit(self, data: Recording | Sequence[Recording]) -> _Baseline:
        """Train on the terminal labels of the training trajectories (early stopping on the rest)."""
        recs = [r.fitting_view() for r in as_recordings(data)]
        if not isinstance(self.window, (int, np.integer)) or isinstance(self.window, bool) or self.window < 1:
            raise ConfigError(f"{self.name}: window must be a positive integer, got {self.window!r}")
        if not 0.0 <= float(self.val_fraction) < 1.0:
            raise ConfigError(f"{self.name}: val_fraction must be in [0, 1), got {self.val_fraction!r}")
        for r in recs:
            r.check_history_window(self.history_frames)
        allrec = Recording.concat(recs) if len(recs) > 1 else recs[0]
        if self.val_fraction > 0:
            if len(allrec.trajectories) < 2:
                raise ConfigError(
                    f"{self.name} needs at least two trajectories (one to train on, one to validate "
                    "for early stopping), or val_fraction=0"
                )
            train, val = allrec.split((1.0 - self.val_fraction, self.val_fraction), seed=self.seed)
        else:
            train, val = allrec, None
        n, n_t = allrec.n_modules, allrec.n_tendons
        mode = self._resolve_mode(n)
        n_inputs = 5 + n_t if mode == "unit" else (n_t + 2) * n  # see _features
        try:
            cfg, schedule = baseline_config(self.kind, self.preset, n_inputs, self.window, n_tendons=n_t)
        except ValueError as exc:
            raise ConfigError(f"{self.name}: {exc}") from None
        self.geometry_ = TransmissionInputs.from_recordings([train], self.robot).geometry
        self.mode_ = mode
        self.n_modules_ = n
        xs, ys, _, _ = self._trajectories([train], with_target=True)
        val_xy = self._trajectories([val], with_target=True)[:2] if val is not None else None
        torch.manual_seed(self.seed)
        net = build_baseline(cfg)
        fit_normalisation(net, xs, ys)
        try:
            hist = train_baseline(
                net,
                (xs, ys),
                val_xy,
                schedule,
                seed=self.seed,
                device=resolve_device(self.device),
                progress=epoch_progress(self.progress),
            )
        except TrainingError as exc:
            raise TendonIdError(str(exc)) from None
        self.net_ = net.cpu().eval()
        self.n_parameters_ = count_parameters(net)
        finite = lambda v: v if v is None or np.isfinite(v) else None  # noqa: E731  (strict JSON: no NaN/Infinity)
        self.history_ = {
            "epochs": [{k: finite(v) for k, v in e.items()} for e in hist.epochs],
            "best_val": finite(hist.best_val),
            "best_epoch": hist.best_epoch,
        }
        return self

    @property
    def n_tendons_(self) -> int:
        """Tendons per set the model was fitted on: the output's width (3 if saved before the count was)."""
        self.check_fitted()
        return int(self.net_.cfg.n_tendons)

    def _check(self, data) -> list[Recording]:
        recs = self._check_data(data)
        check_tendon_count(recs, self.n_tendons_, self.name)
        for r in recs:
            r.check_history_window(self.history_frames)
        return recs

    def predict_chain(self, data: Recording | Sequence[Recording]) -> np.ndarray:
        """``T[k, j, i]`` [N], shape (T, N, N, n): the proximal chain with ``T[N, N]`` estimated.

        NaN where ``k > j``.
        """
        recs = self._check(data)
        xs, _, bounds, inp = self._trajectories(recs, with_target=False)
        log_ratio = predict_log_ratio(self.net_, xs)
        act = inp.actuator
        n = inp.n_modules
        chain = np.broadcast_to(act[:, None], (inp.n_frames, n, n, act.shape[-1])).copy()  # no estimate: actuator side
        for (s, e), lr in zip(bounds, log_ratio):
            chain[s:e, n - 1, n - 1] = act[s:e, n - 1] * np.exp(lr)
        chain[:, np.arange(n)[:, None] > np.arange(n)[None, :]] = np.nan
        return chain

    # ---- persistence -----------------------------------------------------------------------------
    def _state(self):
        state = {
            "n_modules": self.n_modules_,
            "mode": self.mode_,
            "geometry": self.geometry_.to_dict(),
            "config": _config_doc(self.net_.cfg),
            "n_parameters": self.n_parameters_,
            "history": self.history_,
        }
        return state, weights_array(self.net_)

    def _restore(self, state, arrays):
        self.n_modules_ = int(state["n_modules"])
        self.mode_ = str(state["mode"])
        self.geometry_ = RobotGeometry.from_dict(state["geometry"])
        cfg = dict(state["config"])
        cfg["hidden"] = tuple(cfg["hidden"])
        self.net_ = load_weights(lambda: build_baseline(BaselineConfig(**cfg)), arrays)
        self.n_parameters_ = int(state.get("n_parameters", count_parameters(self.net_)))
        self.history_ = state.get("history", {})


def _config_doc(cfg: BaselineConfig) -> dict:
    """``cfg`` as saved: the paper's tendon count left out, so that a 3-tendon model's files are as they were
    before the count existed (and a file without it loads as 3, the field's default)."""
    doc = asdict(cfg)
    if doc["n_tendons"] == 3:
        del doc["n_tendons"]
    return doc


class MLPBaseline(_Baseline):
    __doc__ = 'Static MLP baseline (paper Table I, "MLP [15]"): the current frame only, like ``f_theta``.\n' + (
        _Baseline.__doc__ or ""
    )
    name = "mlp"
    kind = "mlp"


class LSTMBaseline(_Baseline):
    __doc__ = (
        'Causal LSTM baseline (paper Table I, "LSTM [16]"): trained on chunks, stateful over each trajectory '
        "at prediction.\n" + (_Baseline.__doc__ or "")
    )
    name = "lstm"
    kind = "lstm"


class TransformerBaseline(_Baseline):
    __doc__ = (
        'Causal Transformer baseline (paper Table I, "Transformer [13]"): sliding-window attention over the '
        "last ``window`` frames per layer.\n" + (_Baseline.__doc__ or "")
    )
    name = "transformer"
    kind = "transformer"
