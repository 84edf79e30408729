"""The PG-CHTM unit (paper Section III-C): a static MLP backbone times a causal temporal residual.

``r_data = (1 + r_TR) * r_MLP`` (paper Eq. (8)), with ``r_MLP = softplus(f_theta(x)) + 0.01``
and ``r_TR = 0.5 tanh(g_phi(x_{t-h+1..t}))`` in ``(-0.5, 0.5)``.

``g_phi`` is a strictly causal Transformer with sliding-window attention: at every
layer a frame attends to itself and the ``h - 1`` frames before it, with a learned
bias per head and lag instead of absolute positions.  Being translation invariant,
its per-frame computation can be cached, so streaming costs O(1) per frame and agrees
with batch inference; with ``L`` layers an output can draw on ``L (h - 1) + 1`` frames.
"""

from __future__ import annotations

import math

import torch
from torch import Tensor, nn
from torch.nn import functional as F

from learners.presets import UnitConfig

#: Geometric unit inputs of paper Eq. (7), ``[sin(q_k) (4), cos(alpha_k) (1)]``; the tensions follow them.
N_GEOMETRY = 5
EPSILON = 0.01  # paper: r_MLP = softplus(.) + 0.01


def n_features(n_tendons: int) -> int:
    """Unit inputs of paper Eq. (7) for ``n_tendons`` tendons per set: the geometry, then one tension per tendon.

    ``[sin(q_k) (4), cos(alpha_k) (1), normalised T_k (n)]``: 8 for the paper's three tendons.
    """
    return N_GEOMETRY + int(n_tendons)


def gelu_mlp_body(n_in: int, hidden: tuple[int, ...]) -> tuple[nn.Sequential, int]:
    """Linear → BatchNorm1d → GELU per hidden layer (paper §IV-B's ``f_theta`` body); returns it and its width."""
    layers: list[nn.Module] = []
    width = n_in
    for h in hidden:
        layers += [nn.Linear(width, h), nn.BatchNorm1d(h), nn.GELU()]
        width = h
    return nn.Sequential(*layers), width


class StaticBackbone(nn.Module):
    """``f_theta``: Linear → BatchNorm1d → GELU per hidden layer, then softplus + 0.01 (paper §IV-B).

    Parameters
    ----------
    hidden : tuple of int
        Widths of the hidden layers.
    n_tendons : int
        Tendons per set ``n``: ``n_features(n)`` inputs, one ratio per tendon out.
    """

    def __init__(self, hidden: tuple[int, ...] = (512, 512, 256), n_tendons: int = 3):
        super().__init__()
        self.n_tendons = int(n_tendons)
        self.body, width = gelu_mlp_body(n_features(self.n_tendons), hidden)
        self.head = nn.Linear(width, self.n_tendons)

    def forward(self, x: Tensor) -> Tensor:
        """Ratios ``r_MLP > 0.01`` [-], shape ``x.shape[:-1] + (n,)``."""
        flat = x.reshape(-1, n_features(self.n_tendons))
        out = self.head(self.body(flat))
        return (F.softplus(out) + EPSILON).reshape(*x.shape[:-1], self.n_tendons)


class SlidingWindowAttention(nn.Module):
    """Causal multi-head self-attention over the last ``window`` frames, with a learned lag bias."""

    def __init__(self, d_model: int, n_heads: int, window: int):
        super().__init__()
        self.h = n_heads
        self.dk = d_model // n_heads
        self.window = window
        self.qkv = nn.Linear(d_model, 3 * d_model)
        self.out = nn.Linear(d_model, d_model)
        self.lag_bias = nn.Parameter(torch.zeros(n_heads, window))  # bias[h, lag], lag = 0..window-1

    def _split(self, x: Tensor) -> Tensor:
        return x.view(*x.shape[:-1], self.h, self.dk)

    def forward(self, x: Tensor, valid: Tensor) -> Tensor:
        """Whole sequences at once.

        Parameters
        ----------
        x : Tensor, shape (B, L, d)
        valid : Tensor of bool, shape (B, L, window)
            ``valid[b, t, lag]``: frame ``t - lag`` exists in the same trajectory.
        """
        b, L, _ = x.shape
        q, k, v = self.qkv(x).chunk(3, dim=-1)
        q, k, v = self._split(q), self._split(k), self._split(v)  # (B, L, H, dk)
        pad = self.window - 1
        kp = F.pad(k, (0, 0, 0, 0, pad, 0))  # (B, L+pad, H, dk)
        vp = F.pad(v, (0, 0, 0, 0, pad, 0))
        # Keys of lags 0..window-1 for every frame: (B, L, window, H, dk), lag 0 first.
        kw = kp.unfold(1, self.window, 1).permute(0, 1, 4, 2, 3).flip(2)
        vw = vp.unfold(1, self.window, 1).permute(0, 1, 4, 2, 3).flip(2)
        scores = torch.einsum("blhd,blwhd->blhw", q, kw) / math.sqrt(self.dk) + self.lag_bias
        scores = scores.masked_fill(~valid[:, :, None, :], float("-inf"))
        att = torch.softmax(scores, dim=-1)
        y = torch.einsum("blhw,blwhd->blhd", att, vw).reshape(b, L, -1)
        return self.out(y)

    def ring_bias(self, lag_of_slot: Tensor, invalid: Tensor) -> Tensor:
        """Lag bias of every slot of a ring cache, ``-inf`` where the slot holds no frame of this trajectory.

        Parameters
        ----------
        lag_of_slot : Tensor of int, shape (window,)
            How many frames ago the frame in each slot was seen (0: the current frame).
        invalid : Tensor of bool, shape (window,)
            Slots not (yet) holding a frame of the current trajectory.

        Returns
        -------
        Tensor, shape (H, 1, window)
        """
        return self.lag_bias.index_select(1, lag_of_slot).masked_fill(invalid, float("-inf"))[:, None, :]

    def step(self, x: Tensor, keys: Tensor, values: Tensor, slot: Tensor, bias: Tensor) -> Tensor:
        """One new frame per stream, attending to a ring cache of the last ``window`` frames.

        The cache is a ring: the new frame's key and value overwrite, in place, the slot of
        the frame ``window`` frames ago, so nothing else is copied.  Attention does not care
        in which order keys are stored; the lag of each slot enters only through ``bias``.

        Parameters
        ----------
        x : Tensor, shape (S, d)
        keys : Tensor, shape (S, H, dk, window)
            Keys, stored transposed so that the scores are one batched matmul; updated in place.
        values : Tensor, shape (S, H, window, dk)
            Updated in place.
        slot : Tensor of int, shape (1,)
            The slot the new frame goes to.
        bias : Tensor, shape (H, 1, window)
            From :meth:`ring_bias`.
        """
        s = x.shape[0]
        q, k, v = self.qkv(x).chunk(3, dim=-1)
        keys.index_copy_(3, slot, k.reshape(s, self.h, self.dk, 1))
        values.index_copy_(2, slot, v.reshape(s, self.h, 1, self.dk))
        scores = torch.matmul(q.reshape(s, self.h, 1, self.dk), keys) / math.sqrt(self.dk) + bias  # (S, H, 1, window)
        y = torch.matmul(torch.softmax(scores, dim=-1), values).reshape(s, -1)
        return self.out(y)


class SlidingWindowLayer(nn.Module):
    """A pre-norm Transformer layer: sliding-window causal attention, then a GELU feed-forward."""

    def __init__(self, d_model: int, n_heads: int, window: int, d_ff: int):
        super().__init__()
        self.norm1 = nn.LayerNorm(d_model)
        self.attn = SlidingWindowAttention(d_model, n_heads, window)
        self.norm2 = nn.LayerNorm(d_model)
        self.ff = nn.Sequential(nn.Linear(d_model, d_ff), nn.GELU(), nn.Linear(d_ff, d_model))

    def forward(self, h: Tensor, valid: Tensor) -> Tensor:
        h = h + self.attn(self.norm1(h), valid)
        return h + self.ff(self.norm2(h))


class TemporalResidual(nn.Module):
    """``g_phi``: pre-norm causal Transformer layers with sliding-window attention; ``0.5 tanh`` head.

    ``n_tendons`` (``n``) sets its width: ``n_features(n)`` inputs per frame, one residual per tendon out.
    """

    def __init__(self, cfg: UnitConfig, n_tendons: int = 3):
        super().__init__()
        self.cfg = cfg
        self.n_tendons = int(n_tendons)
        self.embed = nn.Linear(n_features(self.n_tendons), cfg.d_model)
        self.layers = nn.ModuleList(
            SlidingWindowLayer(cfg.d_model, cfg.n_heads, cfg.window, cfg.d_ff) for _ in range(cfg.n_layers)
        )
        self.norm = nn.LayerNorm(cfg.d_model)
        self.head = nn.Linear(cfg.d_model, self.n_tendons)
        nn.init.zeros_(self.head.weight)  # start as "no residual": r_TR = 0
        nn.init.zeros_(self.head.bias)

    def forward(self, x: Tensor, valid: Tensor) -> Tensor:
        """``r_TR`` for every frame of sequences ``x`` (B, L, 5 + n), shape (B, L, n)."""
        h = self.embed(x)
        for layer in self.layers:
            h = layer(h, valid)
        return 0.5 * torch.tanh(self.head(self.norm(h)))

    def ring_biases(self, lag_of_slot: Tensor, invalid: Tensor) -> list[Tensor]:
        """Each layer's :meth:`SlidingWindowAttention.ring_bias` for the current frame."""
        return [layer.attn.ring_bias(lag_of_slot, invalid) for layer in self.layers]

    def step(self, x: Tensor, cache: list[Tensor], slot: Tensor, biases: list[Tensor]) -> Tensor:
        """``r_TR`` (S, n) of one new frame per stream (S, 5 + n), writing its keys and values into the ring ``cache``.

        ``cache`` holds each layer's keys and values, ``[k_1, v_1, k_2, v_2, ...]``, as made
        by :meth:`empty_cache`; ``biases`` come from :meth:`ring_biases`.
        """
        h = self.embed(x)
        for i, layer in enumerate(self.layers):
            h = h + layer.attn.step(layer.norm1(h), cache[2 * i], cache[2 * i + 1], slot, biases[i])
            h = h + layer.ff(layer.norm2(h))
        return 0.5 * torch.tanh(self.head(self.norm(h)))

    def empty_cache(self, n_streams: int, device=None, dtype=None) -> list[Tensor]:
        """Zeroed ring caches for ``n_streams`` streams: ``[keys, values]`` per layer."""
        c = self.cfg
        dk = c.d_model // c.n_heads
        out = []
        for _ in range(c.n_layers):
            out += [
                torch.zeros((n_streams, c.n_heads, dk, c.window), device=device, dtype=dtype),
                torch.zeros((n_streams, c.n_heads, c.window, dk), device=device, dtype=dtype),
            ]
        return out


class PGCHTMUnit(nn.Module):
    """One physics-guided cable-hole transmission unit: ``r_data = (1 + r_TR) r_MLP`` (paper Eq. (8)).

    It maps a guide's ``n_features(n)`` inputs (paper Eq. (7)) to one ratio per tendon of the set.
    """

    def __init__(self, cfg: UnitConfig, n_tendons: int = 3):
        super().__init__()
        self.cfg = cfg
        self.n_tendons = int(n_tendons)
        self.backbone = StaticBackbone(cfg.hidden, self.n_tendons)
        self.residual = TemporalResidual(cfg, self.n_tendons) if cfg.temporal_residual else None
