"""The PG-CHTC cascade (paper Algorithm 1): one unit per guide, parameters tied across guides.

Batch inference runs every guide once over whole sequences, vectorised over time and
tendon sets; only the N - 1 guides are a Python loop, since guide k + 1 is fed by guide k.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import torch
from torch import Tensor, nn

from learners.presets import UnitConfig
from learners.unit import N_GEOMETRY, PGCHTMUnit, n_features


@dataclass
class CascadeInputs:
    """What the cascade reads, per frame (built by the caller from a recording).

    Attributes
    ----------
    sin_q : Tensor, shape (B, L, N-1, 4)
        ``sin`` of the adjacent joint angles ``q_k = (theta_k, theta_{k+1})`` (paper Eq. (2)).
    alpha : Tensor, shape (B, L, N-1)
        Backbone wrap of each guide [rad] (paper Eq. (3)).
    log_actuator : Tensor, shape (B, L, S, n)
        ``ln T[1, j, i]`` of the sets to propagate, ``n`` tendons per set.
    since_start : Tensor of int, shape (B, L)
        Frames since the start of the trajectory (or of the chunk, if later): how far back
        the temporal residual may look.
    """

    sin_q: Tensor
    alpha: Tensor
    log_actuator: Tensor
    since_start: Tensor

    def to(self, device) -> CascadeInputs:
        return CascadeInputs(*(t.to(device) for t in (self.sin_q, self.alpha, self.log_actuator, self.since_start)))


#: Bound on a single guide's log ratio.  Physical capstan ratios are within exp(+-1); the bound
#: only keeps an untrained or diverging model finite in float32 over the whole chain.
LOG_RATIO_BOUND = 6.0


def normalised_geometry(sin_q: Tensor, alpha: Tensor, mean: Tensor, std: Tensor) -> Tensor:
    """The geometric unit inputs of paper Eq. (7), ``[sin q_k (4), cos alpha_k]``, channel-normalised.

    Parameters
    ----------
    sin_q : Tensor, shape (..., 4)
        ``sin`` of the adjacent joint angles of each guide.
    alpha : Tensor, shape (...)
        The guide's wrap angle [rad].
    mean, std : Tensor, shape (5 + n,)
        The channel normalisation fitted on training data (its first 5 channels are read).

    Returns
    -------
    Tensor, shape (..., 5), in ``mean``'s dtype (computed in float64).

    Notes
    -----
    The unit inputs are normalised in float64 and only then rounded to the units' dtype.
    ``cos(alpha)`` spans a few 1e-3 just below 1 and the tensions spread little about their
    mean, so ``(x - mean) / std`` done in float32 amplifies their rounding by ``|x| / std``:
    on a trained ``fast`` model that alone moved ``ln r`` by about 3e-6 per guide, ten times
    the units' own float32 rounding, and set the streaming engines 1e-5 apart.
    """
    d = torch.float64
    x = torch.cat([sin_q.to(d), torch.cos(alpha.to(d))[..., None]], dim=-1)
    return ((x - mean[:N_GEOMETRY].to(d)) / std[:N_GEOMETRY].to(d)).to(mean.dtype)


def normalised_tensions(log_t: Tensor, mean: Tensor, std: Tensor) -> Tensor:
    """The tension inputs of paper Eq. (7) from ``ln T`` (..., n) [ln N], channel-normalised, in ``mean``'s dtype.

    ``mean`` and ``std`` have ``5 + n`` channels, the tensions' last. Computed in float64, for the
    reason given in :func:`normalised_geometry`.
    """
    d = torch.float64
    return ((torch.exp(log_t.to(d)) - mean[N_GEOMETRY:].to(d)) / std[N_GEOMETRY:].to(d)).to(mean.dtype)


class Cascade(nn.Module):
    """PG-CHTC: shared (``tied``) or per-guide PG-CHTM units chained over the guides.

    Parameters
    ----------
    n_guides : int
        ``N - 1``.
    cfg : UnitConfig
    tied : bool
        One unit for every guide (the paper), or one per guide (identifiability comparison).
    n_tendons : int
        Tendons per set ``n`` (the paper's 3): each unit reads ``5 + n`` inputs and gives ``n`` ratios.
    """

    def __init__(self, n_guides: int, cfg: UnitConfig, tied: bool = True, n_tendons: int = 3):
        super().__init__()
        self.n_guides = n_guides
        self.cfg = cfg
        self.tied = tied
        self.n_tendons = int(n_tendons)
        self.units = nn.ModuleList(PGCHTMUnit(cfg, self.n_tendons) for _ in range(1 if tied else n_guides))
        # Channel normalisation of the 5 + n unit inputs, fitted on training data (paper §III-C).
        self.register_buffer("feature_mean", torch.zeros(n_features(self.n_tendons)))
        self.register_buffer("feature_std", torch.ones(n_features(self.n_tendons)))

    def unit(self, g: int) -> PGCHTMUnit:
        return self.units[0 if self.tied else g]

    def forward(self, inp: CascadeInputs, sets: Tensor, *, residual: bool = True) -> tuple[Tensor, Tensor]:
        """Propagate through every guide.

        Parameters
        ----------
        inp : CascadeInputs
        sets : Tensor of int, shape (S,)
            0-based indices of the sets in ``inp.log_actuator``'s third axis.
        residual : bool
            Use ``g_phi`` (off in stage 1 of training).

        Returns
        -------
        log_joint : Tensor of float64, shape (B, L, S, n)
            ``ln T_hat[j, j, i]`` of each set.
        log_ratio : Tensor, shape (B, L, N-1, S, n)
            ``ln r_data`` per guide (0 where the set does not pass the guide).
        """
        b, L = inp.log_actuator.shape[:2]
        # The chain is summed in float64, as predict_chain's cumulative sum of the log ratios is:
        # in float32 each guide would round ln T (about 4) by up to 2.4e-7.
        log_t = inp.log_actuator.to(torch.float64)
        log_ratio = inp.log_actuator.new_zeros((b, L, self.n_guides) + log_t.shape[2:], dtype=self.feature_mean.dtype)
        lags = torch.arange(self.cfg.window, device=log_t.device)
        valid = lags[None, None, :] <= inp.since_start[..., None]  # (B, L, window)
        geo = normalised_geometry(inp.sin_q, inp.alpha, self.feature_mean, self.feature_std)  # (B, L, N-1, 5)
        for g in range(self.n_guides):
            active = sets > g  # set j (index j-1) passes guide k = g + 1 iff k < j
            if not bool(active.any()):
                break
            x_t = log_t[:, :, active]
            x = torch.cat(
                [
                    geo[:, :, g, None, :].expand(*x_t.shape[:-1], N_GEOMETRY),
                    normalised_tensions(x_t, self.feature_mean, self.feature_std),
                ],
                dim=-1,
            )  # (B, L, Sa, 5 + n)
            unit = self.unit(g)
            lr = torch.log(unit.backbone(x))
            if residual and unit.residual is not None:
                sa = x.shape[2]
                seq = x.permute(0, 2, 1, 3).reshape(b * sa, L, -1)
                r_tr = unit.residual(seq, valid.repeat_interleave(sa, dim=0))
                r_tr = r_tr.reshape(b, sa, L, self.n_tendons).permute(0, 2, 1, 3)
                lr = lr + torch.log1p(r_tr)
            lr = lr.clamp(-LOG_RATIO_BOUND, LOG_RATIO_BOUND)
            log_t = log_t.clone()
            log_t[:, :, active] = x_t + lr.to(torch.float64)
            log_ratio[:, :, g, active] = lr
        return log_t, log_ratio


def folded_backbone(backbone) -> list[tuple[Tensor, Tensor]]:
    """``f_theta``'s layers with each eval-mode BatchNorm folded into the Linear before it.

    Parameters
    ----------
    backbone : StaticBackbone
        Its ``body`` is Linear, BatchNorm1d, activation per hidden layer, then ``head``.

    Returns
    -------
    list of (Tensor, Tensor)
        ``(weight (in, out), bias (out,))`` per Linear layer, hidden layers first: the weight
        transposed for ``x @ weight + bias``, as the streaming engines apply it.
    """
    layers = list(backbone.body)
    out = []
    for i in range(0, len(layers), 3):
        lin, bn = layers[i], layers[i + 1]
        scale = bn.weight / torch.sqrt(bn.running_var + bn.eps)
        out.append(((lin.weight * scale[:, None]).T.contiguous(), (lin.bias - bn.running_mean) * scale + bn.bias))
    out.append((backbone.head.weight.T.contiguous(), backbone.head.bias.clone()))
    return out


class StreamingCascade:
    """Frame-by-frame inference with causal caches: O(1) work per frame (paper Algorithm 1).

    Per guide and set it keeps, for every attention layer, the keys and values of the last
    ``h`` frames in a ring buffer that each new frame overwrites in place, so a new frame
    costs one backbone call and one attention step per layer, batched over the sets at
    each guide, and copies nothing it does not change.  The backbone's BatchNorm layers
    are folded into its Linear layers once, at construction.

    A frame is hundreds of small operations, so on a CPU their dispatch costs as much as
    their arithmetic.  With ``compiled=True`` the whole frame (every guide, every layer) is
    traced once into a frozen TorchScript graph, which runs the same operations in the
    same order (the same rounding) with less overhead per operation; where tracing is not
    possible the eager step is used.
    """

    def __init__(self, cascade: Cascade, n_sets: int, compiled: bool = True):
        self.cascade = cascade.eval()
        self.n_sets = n_sets
        window = cascade.cfg.window
        p = next(cascade.parameters())
        with torch.no_grad():
            self.backbones = [folded_backbone(u.backbone) for u in cascade.units]
        # Ring bookkeeping for every (slot, frames seen) state, built once: a frame only picks them.
        slots = torch.arange(window, device=p.device)
        self._slot = [torch.tensor([s], device=p.device) for s in range(window)]
        self._lag = [(s - slots) % window for s in range(window)]  # lag of each slot when the newest is in slot s
        self._invalid = [[lag > seen for seen in range(window)] for lag in self._lag]  # [slot][min(seen, window-1)]
        self.reset()
        self._graph = self._trace() if compiled else None

    def reset(self) -> None:
        """Forget the history (call at the start of a trajectory)."""
        c = self.cascade
        p = next(c.parameters())
        caches: list[Tensor] = []
        for g in range(c.n_guides):
            unit = c.unit(g)
            if unit.residual is not None:
                caches += unit.residual.empty_cache(self.n_sets - (g + 1), p.device, p.dtype)
        self.caches = tuple(caches)
        self.n_seen = 0

    def _backbone(self, g: int, x: Tensor) -> Tensor:
        layers = self.backbones[0 if self.cascade.tied else g]
        h = x
        for w, b in layers[:-1]:
            h = torch.nn.functional.gelu(torch.addmm(b, h, w))
        w, b = layers[-1]
        return torch.nn.functional.softplus(torch.addmm(b, h, w)) + 0.01

    def _frame(
        self,
        sin_q: Tensor,
        alpha: Tensor,
        log_actuator: Tensor,
        slot: Tensor,
        lag_of_slot: Tensor,
        invalid: Tensor,
        caches: tuple[Tensor, ...],
    ) -> Tensor:
        """One frame from explicit state (the caches are updated in place): what the eager and traced steps run."""
        c = self.cascade
        mean, std = c.feature_mean, c.feature_std
        geo = normalised_geometry(sin_q, alpha, mean, std)  # (N-1, 5): the geometric inputs of every guide
        biases = [u.residual.ring_biases(lag_of_slot, invalid) if u.residual is not None else [] for u in c.units]
        done = [log_actuator[:1]]  # set j is final once it has passed guide j - 1
        x_t = log_actuator[1:]  # float64, as in Cascade.forward
        k = 0
        for g in range(c.n_guides):
            x = torch.cat([geo[g].expand(x_t.shape[0], N_GEOMETRY), normalised_tensions(x_t, mean, std)], dim=1)
            lr = torch.log(self._backbone(g, x))
            unit = c.unit(g)
            if unit.residual is not None:
                n = 2 * len(unit.residual.layers)
                r_tr = unit.residual.step(x, list(caches[k : k + n]), slot, biases[0 if c.tied else g])
                k += n
                lr = lr + torch.log1p(r_tr)
            out = x_t + lr.clamp(-LOG_RATIO_BOUND, LOG_RATIO_BOUND).to(torch.float64)
            done.append(out[:1])
            x_t = out[1:]
        return torch.cat(done, dim=0)

    def _trace(self):
        """The frame as a frozen TorchScript graph, or None where tracing fails."""
        engine = self

        class _Frame(nn.Module):
            def __init__(self):
                super().__init__()
                self.cascade = engine.cascade  # its weights are the graph's parameters, frozen below

            def forward(self, sin_q, alpha, log_actuator, slot, lag_of_slot, invalid, caches):
                return engine._frame(sin_q, alpha, log_actuator, slot, lag_of_slot, invalid, caches)

        c = self.cascade
        p = next(c.parameters())
        n = self.n_sets
        # Traced on scratch caches: tracing runs the frame once, and that must not touch the state.
        scratch = tuple(torch.zeros_like(t) for t in self.caches)
        f64 = dict(dtype=torch.float64, device=p.device)
        example = (
            torch.zeros(n - 1, 4, **f64),
            torch.zeros(n - 1, **f64),
            torch.zeros(n, c.n_tendons, **f64),
            self._slot[0],
            self._lag[0],
            self._invalid[0][0],
            scratch,
        )
        try:
            with torch.no_grad(), warnings.catch_warnings():
                # TorchScript is deprecated in favour of torch.compile, which needs a C++ toolchain at
                # run time; torch is pinned (2.13), and without TorchScript the eager step runs instead.
                warnings.simplefilter("ignore", DeprecationWarning)
                graph = torch.jit.trace(_Frame().eval(), example, check_trace=False)
                return torch.jit.freeze(graph.eval())
        except Exception:  # pragma: no cover - a backend without TorchScript: the eager step is exact too
            return None

    @torch.inference_mode()
    def step(self, sin_q: Tensor, alpha: Tensor, log_actuator: Tensor) -> Tensor:
        """Joint-side ``ln T_hat[j, j, :]`` of all sets for one frame, float64 of shape (N, n).

        Parameters
        ----------
        sin_q : Tensor, shape (N-1, 4)
        alpha : Tensor, shape (N-1,)
        log_actuator : Tensor, shape (N, n)
            Any floating dtype; the features and the chain are computed in float64, the units in theirs.
        """
        f64 = lambda t: t.to(torch.float64)  # noqa: E731
        sin_q, alpha, log_actuator = f64(sin_q), f64(alpha), f64(log_actuator)
        window = self.cascade.cfg.window
        slot = self.n_seen % window
        run = self._graph if self._graph is not None else self._frame
        log_t = run(
            sin_q,
            alpha,
            log_actuator,
            self._slot[slot],
            self._lag[slot],
            self._invalid[slot][min(self.n_seen, window - 1)],
            self.caches,
        )
        self.n_seen += 1
        return log_t
