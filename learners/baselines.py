"""Learning-only baselines of the paper's Table I: MLP [15], LSTM [16] and Transformer [13].

Each is a black-box regressor of the terminal set's log transmission ratio
``ln T[N, N] - ln T[1, N]`` from a causal history of per-frame input vectors, so that
``ln T_hat[N, N] = ln T[1, N] + output`` (the log domain of the paper's Eq. (16)); the
training loss is the data term of Eq. (12), ``||ln T_hat[N, N] - ln T[N, N]||^2``
summed over tendons and averaged over frames.  There is no physics prior, no
smoothness term and no guide structure: whatever the inputs are (the 8 unit inputs of
a single passage, or the 5N raw inputs ``X(t)`` of the whole robot), only the terminal
label is fitted.

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
training data (a reparameterisation that does not change the loss).

The training loop is AdamW with cosine learning-rate annealing and early stopping on
validation trajectories (best weights restored), as for PG-CHTC.  It works on arrays
handed in by the caller, one pair ``(x (T_i, F), y (T_i, 3))`` per trajectory.
"""

from __future__ import annotations

import copy
import math
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field

import numpy as np
import torch
from torch import Tensor, nn

from learners.presets import PRESETS as UNIT_PRESETS
from learners.training import TrainingError
from learners.unit import SlidingWindowLayer, gelu_mlp_body

KINDS = ("mlp", "lstm", "transformer")


@dataclass(frozen=True)
class BaselineConfig:
    """Architecture of a baseline.

    Parameters
    ----------
    kind : {"mlp", "lstm", "transformer"}
    n_inputs : int
        Channels per frame (8 for the unit-level form, 5N end to end).
    hidden : tuple of int
        MLP hidden widths (paper preset: 512/512/256, as ``f_theta``).
    lstm_hidden, lstm_layers : int
        LSTM state size and depth (paper preset: 180 x 2, about 400 k parameters).
    d_model, n_heads, n_layers, d_ff : int
        Transformer sizes (paper preset: 128, 4, 3, 256, as ``g_phi``: about 400 k).
    window : int
        Frames each Transformer layer attends to (the current one and ``window - 1`` before).
    """

    kind: str
    n_inputs: int
    hidden: tuple[int, ...] = (512, 512, 256)
    lstm_hidden: int = 180
    lstm_layers: int = 2
    d_model: int = 128
    n_heads: int = 4
    n_layers: int = 3
    d_ff: int = 256
    window: int = 20

    def __post_init__(self) -> None:
        if self.kind not in KINDS:
            raise ValueError(f"unknown baseline {self.kind!r}; known: {', '.join(KINDS)}")
        if self.n_inputs < 1 or self.window < 1 or self.d_model % self.n_heads:
            raise ValueError("n_inputs and window must be >= 1 and d_model divisible by n_heads")

    @property
    def sequential(self) -> bool:
        """Whether the model reads a history (trained on chunks) rather than single frames."""
        return self.kind != "mlp"


@dataclass(frozen=True)
class Schedule:
    """Optimisation schedule: AdamW + cosine annealing + early stopping.

    ``batch`` counts frames for the static MLP and chunks of ``chunk`` frames for the
    sequence models.
    """

    lr: float
    batch: int
    epochs: int
    patience: int
    chunk: int = 256
    weight_decay: float = 1e-4


@dataclass(frozen=True)
class BaselinePreset:
    arch: dict
    static: Schedule
    sequence: Schedule


def _paper() -> BaselinePreset:
    # The paper gives no schedule for its baselines; for a matched comparison the MLP gets
    # f_theta's (stage 1) and the sequence models g_phi's (stage 2), paper Section IV-B.
    t = UNIT_PRESETS["paper"].train
    return BaselinePreset(
        arch={"hidden": (512, 512, 256), "lstm_hidden": 180, "lstm_layers": 2, "d_model": 128, "n_heads": 4, "n_layers": 3, "d_ff": 256},
        static=Schedule(lr=t.lr1, batch=t.batch1, epochs=t.epochs1, patience=t.patience1, weight_decay=t.weight_decay),
        sequence=Schedule(lr=t.lr2, batch=t.batch2, epochs=t.epochs2, patience=t.patience2, chunk=t.chunk2, weight_decay=t.weight_decay),
    )


PRESETS: dict[str, BaselinePreset] = {
    "paper": _paper(),
    # CPU benchmarks (Table I in well under a minute per model on 2 cores).
    "fast": BaselinePreset(
        arch={"hidden": (64, 64, 32), "lstm_hidden": 32, "lstm_layers": 2, "d_model": 32, "n_heads": 4, "n_layers": 2, "d_ff": 64},
        static=Schedule(lr=3e-3, batch=256, epochs=40, patience=6),
        sequence=Schedule(lr=3e-3, batch=8, epochs=80, patience=10, chunk=128),
    ),
    # Unit tests: seconds.
    "tiny": BaselinePreset(
        arch={"hidden": (16, 16, 8), "lstm_hidden": 8, "lstm_layers": 1, "d_model": 8, "n_heads": 2, "n_layers": 1, "d_ff": 16},
        static=Schedule(lr=3e-3, batch=256, epochs=3, patience=2),
        sequence=Schedule(lr=3e-3, batch=8, epochs=3, patience=2, chunk=64),
    ),
}


def baseline_config(kind: str, preset: str, n_inputs: int, window: int = 20) -> tuple[BaselineConfig, Schedule]:
    """The architecture and schedule of baseline ``kind`` in a named preset."""
    if preset not in PRESETS:
        raise ValueError(f"unknown preset {preset!r}; known: {', '.join(PRESETS)}")
    p = PRESETS[preset]
    cfg = BaselineConfig(kind=kind, n_inputs=int(n_inputs), window=int(window), **p.arch)
    return cfg, (p.sequence if cfg.sequential else p.static)


# ---- modules ------------------------------------------------------------------------------------
class _MLPCore(nn.Module):
    def __init__(self, n_in: int, hidden: tuple[int, ...]):
        super().__init__()
        self.body, width = gelu_mlp_body(n_in, hidden)
        self.head = nn.Linear(width, 3)

    def forward(self, x: Tensor, valid: Tensor | None = None) -> Tensor:
        flat = x.reshape(-1, x.shape[-1])
        return self.head(self.body(flat)).reshape(*x.shape[:-1], 3)


class _LSTMCore(nn.Module):
    def __init__(self, n_in: int, hidden: int, layers: int):
        super().__init__()
        self.lstm = nn.LSTM(n_in, hidden, num_layers=layers, batch_first=True)
        self.head = nn.Linear(hidden, 3)

    def forward(self, x: Tensor, valid: Tensor | None = None) -> Tensor:
        h, _ = self.lstm(x)  # zero initial state: the start of a trajectory (or of a chunk)
        return self.head(h)


class _TransformerCore(nn.Module):
    def __init__(self, cfg: BaselineConfig):
        super().__init__()
        self.embed = nn.Linear(cfg.n_inputs, cfg.d_model)
        self.layers = nn.ModuleList(SlidingWindowLayer(cfg.d_model, cfg.n_heads, cfg.window, cfg.d_ff) for _ in range(cfg.n_layers))
        self.norm = nn.LayerNorm(cfg.d_model)
        self.head = nn.Linear(cfg.d_model, 3)

    def forward(self, x: Tensor, valid: Tensor) -> Tensor:
        h = self.embed(x)
        for layer in self.layers:
            h = layer(h, valid)
        return self.head(self.norm(h))


class BaselineNet(nn.Module):
    """A black-box regressor of the terminal log ratio ``ln T[N, N] - ln T[1, N]``.

    ``forward(x, since_start)`` maps raw inputs ``x`` (B, L, F) to log ratios (B, L, 3);
    ``since_start`` (B, L) counts the frames of history available to each frame (only the
    Transformer reads it; the LSTM starts from a zero state at ``L``'s first frame).
    """

    def __init__(self, cfg: BaselineConfig):
        super().__init__()
        self.cfg = cfg
        if cfg.kind == "mlp":
            self.core: nn.Module = _MLPCore(cfg.n_inputs, cfg.hidden)
        elif cfg.kind == "lstm":
            self.core = _LSTMCore(cfg.n_inputs, cfg.lstm_hidden, cfg.lstm_layers)
        else:
            self.core = _TransformerCore(cfg)
        # Start at the training mean (a zero head), as g_phi starts at "no residual".
        nn.init.zeros_(self.core.head.weight)
        nn.init.zeros_(self.core.head.bias)
        self.register_buffer("x_mean", torch.zeros(cfg.n_inputs))
        self.register_buffer("x_std", torch.ones(cfg.n_inputs))
        self.register_buffer("y_mean", torch.zeros(3))
        self.register_buffer("y_std", torch.ones(3))

    def forward(self, x: Tensor, since_start: Tensor | None = None) -> Tensor:
        z = (x - self.x_mean) / self.x_std
        valid = None
        if self.cfg.kind == "transformer":
            if since_start is None:
                since_start = torch.arange(x.shape[1], device=x.device).expand(x.shape[:2])
            lags = torch.arange(self.cfg.window, device=x.device)
            valid = lags[None, None, :] <= since_start[..., None]
        return self.y_mean + self.y_std * self.core(z, valid)


def build_baseline(cfg: BaselineConfig) -> BaselineNet:
    return BaselineNet(cfg)


def count_parameters(net: nn.Module) -> int:
    """Trainable parameters (buffers such as the normalisation statistics excluded)."""
    return sum(p.numel() for p in net.parameters() if p.requires_grad)


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
    y: Tensor  # (B, L, 3)
    lengths: Tensor  # (B,), on the CPU

    @property
    def mask(self) -> Tensor:
        ar = torch.arange(self.x.shape[1], device=self.x.device)
        return ar[None, :] < self.lengths.to(self.x.device)[:, None]


def _pad(xs: Sequence[np.ndarray], ys: Sequence[np.ndarray] | None, device) -> _Padded:
    L = max(len(a) for a in xs)
    f = xs[0].shape[1]
    x = np.zeros((len(xs), L, f), dtype=np.float32)
    y = np.zeros((len(xs), L, 3), dtype=np.float32)
    for i, a in enumerate(xs):
        x[i, : len(a)] = a
        x[i, len(a) :] = a[-1]  # finite padding, masked out (and after the real frames: causal models ignore it)
        if ys is not None:
            y[i, : len(a)] = ys[i]
    return _Padded(torch.as_tensor(x, device=device), torch.as_tensor(y, device=device),
                   torch.as_tensor([len(a) for a in xs], dtype=torch.long))


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
    """Log ratios (T_i, 3) for whole trajectories ``xs`` (T_i, F), each from its first frame.

    Sequence models run causally over each whole trajectory (the LSTM statefully); groups
    of trajectories are batched up to ``max_frames`` padded frames.
    """
    net.eval()
    p = next(net.parameters())
    with _recurrent_threads(net, p.device):
        return _predict(net, xs, max_frames, p)


def _predict(net: BaselineNet, xs: Sequence[np.ndarray], max_frames: int, p: Tensor) -> list[np.ndarray]:
    out: list[np.ndarray] = [np.empty((0, 3))] * len(xs)
    for group in _groups([len(a) for a in xs], max_frames):
        if net.cfg.kind == "mlp":  # frame by frame: no padding needed
            x = torch.as_tensor(np.concatenate([xs[i] for i in group]), dtype=p.dtype, device=p.device)
            y = net(x[:, None])[:, 0].double().cpu().numpy()
            bounds = np.cumsum([0] + [len(xs[i]) for i in group])
            for k, i in enumerate(group):
                out[i] = y[bounds[k] : bounds[k + 1]]
            continue
        pad = _pad([xs[i] for i in group], None, p.device)
        y = net(pad.x).double().cpu().numpy()
        for k, i in enumerate(group):
            out[i] = y[k, : len(xs[i])]
    return out


# ---- training -----------------------------------------------------------------------------------------
@dataclass
class TrainHistory:
    """Per-epoch mean training and validation losses (log domain, Eq. (12))."""

    epochs: list = field(default_factory=list)
    best_val: float = math.inf
    best_epoch: int = 0


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


def train_baseline(net: BaselineNet, train: tuple[Sequence[np.ndarray], Sequence[np.ndarray]],
                   val: tuple[Sequence[np.ndarray], Sequence[np.ndarray]] | None, schedule: Schedule, *, seed: int = 0,
                   device: torch.device | str = "cpu", progress: Callable | None = None) -> TrainHistory:
    """Fit ``net`` to per-trajectory inputs and targets; early stopping on ``val`` when given.

    Parameters
    ----------
    net : BaselineNet
        Its normalisation should already be fitted (:func:`fit_normalisation`).
    train, val : (list of ndarray (T_i, F), list of ndarray (T_i, 3))
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
    tr = _pad(train[0], train[1], device)
    va = _pad(val[0], val[1], device) if val is not None and len(val[0]) else None
    opt = torch.optim.AdamW(net.parameters(), lr=schedule.lr, weight_decay=schedule.weight_decay)
    sched = torch.optim.lr_scheduler.CosineAnnealingLR(opt, T_max=max(schedule.epochs, 1))
    hist = TrainHistory()
    best_state, bad = copy.deepcopy(net.state_dict()), 0
    lengths = tr.lengths.tolist()
    if not net.cfg.sequential:  # every real frame on its own
        fx, fy = tr.x[tr.mask], tr.y[tr.mask]
    desc = f"{net.cfg.kind} baseline"
    epochs = progress(range(schedule.epochs), desc) if progress else range(schedule.epochs)
    for epoch in epochs:
        net.train()
        running, steps = 0.0, 0
        if net.cfg.sequential:
            pieces = _chunks(lengths, schedule.chunk, rng)
            order = torch.randperm(len(pieces), generator=gen).numpy()
            batches = [pieces[order[s : s + schedule.batch]] for s in range(0, len(pieces), schedule.batch)]
        else:
            order = torch.randperm(fx.shape[0], generator=gen).to(device)
            batches = [order[s : s + schedule.batch] for s in range(0, fx.shape[0], schedule.batch)]
        for b in batches:
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
                if len(b) < 2:
                    continue  # BatchNorm needs two frames
                x, y = fx[b][:, None], fy[b][:, None]
                mask = torch.ones(x.shape[:2], dtype=torch.bool, device=device)
                pred = net(x)
            loss = _masked_loss(pred, y, mask)
            if not torch.isfinite(loss):
                raise TrainingError(f"{desc}: the loss became {float(loss)} at epoch {epoch + 1}; "
                                    "lower the learning rate or check the data for non-positive tensions")
            opt.zero_grad(set_to_none=True)
            loss.backward()
            torch.nn.utils.clip_grad_norm_(net.parameters(), 10.0)
            opt.step()
            running += float(loss.detach())
            steps += 1
        sched.step()
        val_loss = _val_loss(net, va) if va is not None else math.nan
        hist.epochs.append({"epoch": epoch + 1, "train": running / max(steps, 1), "val": val_loss})
        if va is None:
            continue
        if val_loss < hist.best_val - 1e-12:
            hist.best_val, hist.best_epoch, bad = val_loss, epoch + 1, 0
            best_state = copy.deepcopy(net.state_dict())
        else:
            bad += 1
            if bad >= schedule.patience:
                break
    if va is not None:
        net.load_state_dict(best_state)
    else:
        hist.best_epoch = len(hist.epochs)
    net.eval()
    return hist
