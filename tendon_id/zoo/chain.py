"""The capstan chain: ``ln T`` of each tendon through the guides, proximal to distal, with the blocks.

Through guide ``k`` the capstan exponent is ``phi = mu_i(alpha) alpha`` times the
exponent blocks' factors (paper Eqs. (4)–(6)); the guide's slip edges are
``ln T_in -/+ phi`` (the edge blocks may move them); the step between them is forward
slip (``ln T_out = ln T_in - phi``) unless a propagation block says otherwise (the
play operator of the nonsmooth capstan); the output blocks act on what leaves the
guide.  Everything is vectorised over frames, sets and tendons; the only Python loop
runs over the guides, because guide ``k + 1`` is fed by guide ``k``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from tendon_id.zoo.blocks import Block, HookContext


@dataclass(frozen=True)
class ExponentTerms:
    """The law-free part of the exponent: ``phi = mu(alpha) * scaled`` (see :func:`exponent_terms`).

    Attributes
    ----------
    cos_alpha : ndarray
        ``cos(alpha)`` of the wrap the law sees, shape ``(T, K, S|1, m|1)``.
    scaled : ndarray
        The wrap times the exponent blocks' factors, same shape [rad].
    ctx : HookContext
    """

    cos_alpha: NDArray
    scaled: NDArray
    ctx: HookContext


def exponent_terms(blocks: Sequence[Block], inputs, values: dict, sets: NDArray, tendons: NDArray) -> ExponentTerms:
    """Apply the ``wrap``, ``routing`` and ``exponent`` blocks: the exponent, short of the law's coefficients."""
    ctx = HookContext(inputs, np.asarray(sets), np.asarray(tendons))
    routing = [b for b in blocks if b.stage == "routing"]
    per_tendon = any(b.stage == "wrap" for b in blocks)
    key = repr([(b.name, sorted(values.get(b.name, {}).items())) for b in routing])
    last = inputs.cache.get("backbone")
    if per_tendon or last is None or last[0] != key:
        alpha = inputs.bend_wrap[:, :, None, None]  # paper Eq. (3)'s half-bends, shared by sets and tendons
        for stage in ("wrap", "routing"):  # a tendon's own turns first, then the fitted routing wrap added to them
            for b in blocks:
                if b.stage == stage:
                    alpha = getattr(b, stage)(alpha, ctx, values.get(b.name, {}))
        last = (key, alpha, np.cos(alpha))
        if not per_tendon:
            # The backbone wrap at this routing wrap, kept with its cosine: calibration evaluates the
            # chain thousands of times while only the law changes.  Read-only, as it is shared.
            for a in last[1:]:
                a.flags.writeable = False
            inputs.cache["backbone"] = last
    _, alpha, cos_alpha = last
    ctx = replace(ctx, alpha=alpha)
    scaled = alpha
    for b in blocks:
        if b.stage == "exponent":
            scaled = b.exponent(scaled, ctx, values.get(b.name, {}))
    return ExponentTerms(cos_alpha, scaled, ctx)


def exponent(mu_law: str, terms: ExponentTerms, A: NDArray, B: NDArray) -> NDArray:
    """Capstan exponent ``phi[t, k, s, i]`` (paper Eq. (5) with the blocks).

    ``A``, ``B`` have shape (G, m) for ``m`` tendons (G = 1: tied); the constant law uses ``B`` as mu.
    """
    if mu_law == "constant":
        return B[None, :, None, :] * terms.scaled
    phi = A[None, :, None, :] * terms.cos_alpha  # in place from here: calibration calls this thousands of times
    phi += B[None, :, None, :]
    phi *= terms.scaled
    return phi


def propagate_chain(
    blocks: Sequence[Block],
    mu_law: str,
    inputs,
    A: NDArray,
    B: NDArray,
    values: dict,
    sets: NDArray,
    tendons: NDArray,
    keep_chain: bool = True,
    terms: ExponentTerms | None = None,
) -> NDArray:
    """Propagate ``ln T`` through the guides (see ``CapstanModel.propagate``).

    Returns the chain ``ln T[k, j, i]``, shape (T, N, S, m) with NaN off the path, or
    with ``keep_chain=False`` only the joint sides ``ln T[j, j, i]``, shape (T, S, m).
    """
    n = inputs.n_modules
    if terms is None:
        terms = exponent_terms(blocks, inputs, values, sets, tendons)
    phi = exponent(mu_law, terms, A, B)  # (T, K, S|1, m)
    key = f"log_in:{sets.tobytes().hex()}:{tendons.tobytes().hex()}"
    log_in = inputs.memo(key, lambda: inputs.log_actuator[:, sets][:, :, tendons])  # (T, S, m)
    chain = np.full((inputs.n_frames, n) + log_in.shape[1:], np.nan) if keep_chain else None
    if keep_chain:
        chain[:, 0] = log_in
    edges = [b for b in blocks if b.stage == "edges"]
    prop = step_block(blocks)
    outputs = [b for b in blocks if b.stage == "guide_output"]
    if prop is not None and not edges and not outputs:
        series = _series(prop, terms, phi, log_in, sets, values.get(prop.name, {}), keep_chain)
        if series is not None:
            final, guides = series
            if keep_chain:
                chain[:, 1:] = guides
            return chain if keep_chain else final
    log_t = log_in.copy()
    for g in range(n - 1):
        active = sets > g  # set j (index j-1) passes guide k = g + 1 iff k < j
        if not active.any():
            break
        x = log_t[:, active]
        ph = phi[:, g]
        ph = np.broadcast_to(ph[:, active] if ph.shape[1] > 1 else ph, x.shape)
        lo = x - ph
        if edges or prop is not None:
            ctx = terms.ctx.at_guide(g, active)
            hi = x + ph
            for b in edges:
                lo, hi = b.edges(lo, hi, ctx, values.get(b.name, {}))
            y = prop.propagate(lo, hi, ctx, values.get(prop.name, {})) if prop is not None else lo
        else:
            y = lo
        if outputs:
            ctx = terms.ctx.at_guide(g, active)
            for b in outputs:
                y = b.guide_output(y, ctx, values.get(b.name, {}))
        log_t[:, active] = y
        if keep_chain:
            chain[:, g + 1, active] = y
    return chain if keep_chain else log_t


def _series(prop: Block, terms: ExponentTerms, phi: NDArray, log_t: NDArray, sets: NDArray, values: dict, keep: bool):
    """The whole chain from the step block's :meth:`~Block.propagate_series`, reshaped; None if it has none."""
    t, s, m = log_t.shape
    k = phi.shape[1]
    n_pass = np.repeat(np.minimum(sets, k), m)  # set j (index j - 1) passes the guides k < j
    flat_phi = np.broadcast_to(phi, (t, k, s, m)).reshape(t, k, s * m)
    out = prop.propagate_series(log_t.reshape(t, s * m), flat_phi, n_pass, terms.ctx, values, keep)
    if out is None:
        return None
    final, chain = out
    return final.reshape(t, s, m), None if chain is None else chain.reshape(t, k, s, m)


def step_block(blocks: Sequence[Block]) -> Block | None:
    """The ``propagate`` block that sets a guide's step: one that refines another (a smooth edge), else the only one."""
    props = [b for b in blocks if b.stage == "propagate"]
    return next((b for b in props if b.requires), props[0] if props else None)


def apply_sensor(blocks: Sequence[Block], tension: NDArray, ctx: HookContext, values: dict) -> NDArray:
    """The sensor blocks on a predicted terminal reading [N], shape (T, m)."""
    for b in blocks:
        if b.stage == "sensor":
            tension = b.sensor(tension, ctx, values.get(b.name, {}))
    return tension
