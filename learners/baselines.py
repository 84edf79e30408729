"""Learning-only baselines of the paper's Table I: MLP [15], LSTM [16] and Transformer [13].

Each is a black-box regressor of the terminal set's log transmission ratio
``ln T[N, N] - ln T[1, N]`` from a causal history of per-frame input vectors, so that
``ln T_hat[N, N] = ln T[1, N] + output`` (the log domain of the paper's Eq. (16)); the
training loss is the data term of Eq. (12), ``||ln T_hat[N, N] - ln T[N, N]||^2``
summed over tendons and averaged over frames.  There is no physics prior, no
smoothness term and no guide structure: whatever the inputs are (the ``5 + n`` unit inputs of
a single passage, or the ``(n + 2) N`` raw inputs ``X(t)`` of the whole robot), only the terminal
label is fitted.  Every output has one log ratio per tendon of the set (``n``, the paper's 3).

* ``mlp``: static, the current frame only; Linear → BatchNorm1d → GELU per hidden layer,
  like ``f_theta``.
* ``lstm``: causal and recurrent; trained on chunks of trajectories (zero state at each
  chunk start) and run statefully over whole trajectories at prediction.
* ``transformer``: pre-norm causal Transformer encoder whose every layer attends to the
  last ``window`` frames (sliding-window attention with a learned lag bias, as ``g_phi``),
  used here as a standalone regressor.

Sizes: in the ``paper`` preset each has about 400 k parameters, matching ``f_theta``
(8→512→512→256→3) as the paper's Section IV-B prescribes; ``fast`` and ``tiny`` are small
sizes for CPUs, benchmarks and tests.  Inputs are standardised per channel and the
output is ``y_mean + y_std * head(...)`` with the target's statistics, both fitted on the
training data (a reparameterisation that does not change the loss).  The networks,
presets and schedules are built in :mod:`learners.baseline_nets` and re-exported here.

Training runs the loop shared with PG-CHTC (:mod:`learners.loop`): AdamW with cosine
learning-rate annealing and early stopping on validation trajectories (best weights
restored).  It works on arrays handed in by the caller, one pair ``(x (T_i, F), y (T_i, n))``
per trajectory.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass

import numpy as np
import torch
from torch import Tensor

from learners.baseline_nets import (
    KINDS,
    PRESETS,
    BaselineConfig,
    BaselineNet,
    BaselinePreset,
    Schedule,
    baseline_config,
    build_baseline,
    count_parameters,
)
from learners.loop import LoopSchedule, TrainHistory, TrainingError, run_training

__all__ = [
    "KINDS",
    "PRESETS",
    "BaselineConfig",
    "BaselineNet",
    "BaselinePreset",
    "Schedule",
    "TrainHistory",
    "TrainingError",
    "baseline_config",
    "build_baseline",
    "count_parameters",
    "fit_normalisation",
    "predict_log_ratio",
    "train_baseline",
]


def fit_normalisation(net: BaselineNet, xs: Sequence[np.ndarray], ys: Sequence[np.ndarray]) -> None:
    """Per-channel mean and standard deviation of inputs and targets, from training data."""
    x = np.concatenate(list(xs))
    y = np.concatenate(list(ys))

    def stats(a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        sd = a.std(0)
        return a.mean(0), np.where(sd > 1e-8, sd, 1.0)

    for (mean, sd), (bm, bs) in ((stats(x), (net.x_mean, net.x_std)), (stats(y), (net.y_mean, net.y_std))):
        bm.copy_(torch.as_tensor(mean, dtype=bm.dtype))
        bs.copy_(torch.as_tensor(sd, dtype=bs.dtype))


@contextmanager
def _recurrent_threads(net: BaselineNet, device: torch.device) -> Iterator[None]:
    """One intra-op thread while an LSTM runs on the CPU (restored afterwards).

    A recurrent net is thousands of tiny per-time-step kernels; with several OpenMP
    threads each one ends in a barrier, and on a busy machine a descheduled thread stalls
    them all: the ``fast`` LSTM of Table I took 80 s with 2 threads on 2 busy cores and
    2.3 s with one.  Small recurrent kernels gain nothing from more threads anyway.
    """
    if net.cfg.kind != "lstm" or device.type != "cpu":
        yield
        return
    before = torch.get_num_threads()
    torch.set_num_threads(1)
    try:
        yield
    finally:
        torch.set_num_threads(before)


# ---- data on the device ----------------------------------------------------------------------------
@dataclass
class _Padded:
    x: Tensor  # (B, L, F)
    y: Tensor  # (B, L, n)
    lengths: Tensor  # (B,), on the CPU

    @property
    def mask(self) -> Tensor:
        ar = torch.arange(self.x.shape[1], device=self.x.device)
        return ar[None, :] < self.lengths.to(self.x.device)[:, None]


def _pad(xs: Sequence[np.ndarray], ys: Sequence[np.ndarray] | None, device, n_out: int) -> _Padded:
    L = max(len(a) for a in xs)
    f = xs[0].shape[1]
    x = np.zeros((len(xs), L, f), dtype=np.float32)
    y = np.zeros((len(xs), L, n_out), dtype=np.float32)
    for i, a in enumerate(xs):
        x[i, : len(a)] = a
        x[i, len(a) :] = a[-1]  # finite padding, masked out (and after the real frames: causal models ignore it)
        if ys is not None:
            y[i, : len(a)] = ys[i]
    return _Padded(
        torch.as_tensor(x, device=device),
        torch.as_tensor(y, device=device),
        torch.as_tensor([len(a) for a in xs], dtype=torch.long),
    )


def _groups(lengths: Sequence[int], max_frames: int) -> list[list[int]]:
    """Consecutive trajectories in groups whose padded size stays under ``max_frames``."""
    groups: list[list[int]] = []
    cur: list[int] = []
    longest = 0
    for i, n in enumerate(lengths):
        if cur and max(longest, n) * (len(cur) + 1) > max_frames:
            groups.append(cur)
            cur, longest = [], 0
        cur.append(i)
        longest = max(longest, n)
    if cur:
        groups.append(cur)
    return groups


@torch.no_grad()
def predict_log_ratio(net: BaselineNet, xs: Sequence[np.ndarray], *, max_frames: int = 65536) -> list[np.ndarray]:
    """Log ratios (T_i, n) for whole trajectories ``xs`` (T_i, F), each from its first frame.

    Sequence models run causally over each whole trajectory (the LSTM statefully); groups
    of trajectories are batched up to ``max_frames`` padded frames.
    """
    net.eval()
    p = next(net.parameters())
    with _recurrent_threads(net, p.device):
        return _predict(net, xs, max_frames, p)


def _predict(net: BaselineNet, xs: Sequence[np.ndarray], max_frames: int, p: Tensor) -> list[np.ndarray]:
    out: list[np.ndarray] = [np.empty((0, net.cfg.n_tendons))] * len(xs)
    for group in _groups([len(a) for a in xs], max_frames):
        if net.cfg.kind == "mlp":  # frame by frame: no padding needed
            x = torch.as_tensor(np.concatenate([xs[i] for i in group]), dtype=p.dtype, device=p.device)
            y = net(x[:, None])[:, 0].double().cpu().numpy()
            bounds = np.cumsum([0] + [len(xs[i]) for i in group])
            for k, i in enumerate(group):
                out[i] = y[bounds[k] : bounds[k + 1]]
            continue
        pad = _pad([xs[i] for i in group], None, p.device, net.cfg.n_tendons)
        y = net(pad.x).double().cpu().numpy()
        for k, i in enumerate(group):
            out[i] = y[k, : len(xs[i])]
    return out


# ---- training ---------------------------------------------------------------------------------------
def _masked_loss(pred: Tensor, y: Tensor, mask: Tensor) -> Tensor:
    err = ((pred - y) ** 2).sum(-1)
    m = mask.to(err.dtype)
    return (err * m).sum() / m.sum().clamp_min(1.0)


def _val_loss(net: BaselineNet, val: _Padded, max_frames: int = 65536) -> float:
    net.eval()
    total, frames = 0.0, 0.0
    with torch.no_grad():
        for group in _groups(val.lengths.tolist(), max_frames):
            idx = torch.as_tensor(group, device=val.x.device)
            lengths = val.lengths[group]
            L = int(lengths.max())
            x, y = val.x[idx, :L], val.y[idx, :L]
            mask = torch.arange(L, device=x.device)[None, :] < lengths.to(x.device)[:, None]
            loss = _masked_loss(net(x), y, mask)
            n = float(mask.sum())
            total += float(loss) * n
            frames += n
    return total / max(frames, 1.0)


def _chunks(lengths: Sequence[int], chunk: int, rng: np.random.Generator) -> np.ndarray:
    """Pieces (trajectory, start, end) of at most ``chunk`` frames, with a random phase per trajectory."""
    pieces = []
    for i, n in enumerate(lengths):
        phase = int(rng.integers(0, chunk)) if n > chunk else 0
        cuts = [0] + list(range(phase if phase > 0 else chunk, n, chunk)) + [n]
        pieces += [(i, s, e) for s, e in zip(cuts[:-1], cuts[1:]) if e > s]
    return np.asarray(pieces, dtype=np.int64)


def train_baseline(
    net: BaselineNet,
    train: tuple[Sequence[np.ndarray], Sequence[np.ndarray]],
    val: tuple[Sequence[np.ndarray], Sequence[np.ndarray]] | None,
    schedule: Schedule,
    *,
    seed: int = 0,
    device: torch.device | str = "cpu",
    progress: Callable | None = None,
) -> TrainHistory:
    """Fit ``net`` to per-trajectory inputs and targets; early stopping on ``val`` when given.

    Parameters
    ----------
    net : BaselineNet
        Its normalisation should already be fitted (:func:`fit_normalisation`).
    train, val : (list of ndarray (T_i, F), list of ndarray (T_i, n))
        Inputs and target log ratios, one array per trajectory. Without ``val`` the model
        trains for ``schedule.epochs`` epochs and keeps its last weights.
    schedule : Schedule
    seed : int
        Seeds the chunk phases and the batch order (seed ``torch`` yourself for the weights).
    device : torch.device or str
    progress : callable, optional
        ``progress(iterable, desc)`` wraps the epoch loop (e.g. a tqdm bar).

    Returns
    -------
    TrainHistory
        The best weights (lowest validation loss) are restored in ``net``, which is left on
        ``device`` in eval mode.

    Raises
    ------
    TrainingError
        When the loss stops being finite.
    """
    device = torch.device(device)
    net.to(device)
    with _recurrent_threads(net, device):
        return _train(net, train, val, schedule, seed, device, progress)


def _train(net: BaselineNet, train, val, schedule: Schedule, seed: int, device: torch.device, progress) -> TrainHistory:
    rng = np.random.default_rng(seed)
    gen = torch.Generator().manual_seed(seed)
    n_out = net.cfg.n_tendons
    tr = _pad(train[0], train[1], device, n_out)
    va = _pad(val[0], val[1], device, n_out) if val is not None and len(val[0]) else None
    lengths = tr.lengths.tolist()
    if not net.cfg.sequential:  # every real frame on its own
        fx, fy = tr.x[tr.mask], tr.y[tr.mask]

    def batches() -> list:
        if net.cfg.sequential:  # the chunk phases first (numpy), then the order (torch), as always
            pieces = _chunks(lengths, schedule.chunk, rng)
            order = torch.randperm(len(pieces), generator=gen).numpy()
            return [pieces[order[s : s + schedule.batch]] for s in range(0, len(pieces), schedule.batch)]
        order = torch.randperm(fx.shape[0], generator=gen).to(device)
        # BatchNorm needs two frames: a last batch of one is left out (and not counted in the mean)
        frames = (order[s : s + schedule.batch] for s in range(0, fx.shape[0], schedule.batch))
        return [b for b in frames if len(b) >= 2]

    def batch_loss(b) -> tuple[Tensor, None]:
        if net.cfg.sequential:
            traj = torch.as_tensor(b[:, 0], device=device)
            start = torch.as_tensor(b[:, 1], device=device)
            n = torch.as_tensor(b[:, 2] - b[:, 1], device=device)
            L = int(n.max())
            ar = torch.arange(L, device=device)
            idx = (start[:, None] + ar[None, :]).clamp_max(tr.x.shape[1] - 1)
            x, y = tr.x[traj[:, None], idx], tr.y[traj[:, None], idx]
            mask = ar[None, :] < n[:, None]
            pred = net(x, ar.expand(len(b), L))  # no history before the chunk
        else:
            x, y = fx[b][:, None], fy[b][:, None]
            mask = torch.ones(x.shape[:2], dtype=torch.bool, device=device)
            pred = net(x)
        return _masked_loss(pred, y, mask), None

    loop = LoopSchedule(
        lr=schedule.lr, epochs=schedule.epochs, patience=schedule.patience, weight_decay=schedule.weight_decay
    )
    return run_training(
        net,
        list(net.parameters()),
        loop,
        batches=batches,
        batch_loss=batch_loss,
        validate=(lambda: _val_loss(net, va)) if va is not None else None,
        progress=progress,
        desc=f"{net.cfg.kind} baseline",
    )
