"""The capstan chain: ``ln T`` of each tendon through the guides, proximal to distal, with the blocks.

Through guide ``k`` the capstan exponent is ``phi = mu_i(alpha) alpha`` times the
exponent blocks' factors (paper Eqs. (4)–(6)); the guide's slip edges are
``ln T_in -/+ phi`` (the edge blocks may move them); the step between them is forward
slip (``ln T_out = ln T_in - phi``) unless a propagation block says otherwise (the
play operator of the nonsmooth capstan); the output blocks act on what leaves the
guide.  Everything is vectorised over frames, sets and tendons; the only Python loop
runs over the guides, because guide ``k + 1`` is fed by guide ``k``.  The chain starts from the
actuator-side readings as the ``actuator`` blocks correct them (a cell's calibration error, and in
its exact form its lag, undone), and the ``sensor`` blocks turn its terminal tension into the
terminal cell's reading.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from tendon_id.errors import ConfigError
from tendon_id.zoo.blocks import Block, HookContext

#: Smallest tension [N] whose logarithm the chain takes from the actuator stage: an offset larger
#: than a low reading, or a lag's inverse amplifying its noise, may give one at or below zero.
FLOOR_N = 1e-3


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
    # Factors first, then filters over time (a lag of the wrap), which act on the whole exponent.
    for b in sorted((b for b in blocks if b.stage == "exponent"), key=lambda b: not b.multiplier):
        scaled = b.exponent(scaled, ctx, values.get(b.name, {}))
    return ExponentTerms(cos_alpha, scaled, ctx)


def exponent(mu_law: str, terms: ExponentTerms, A: NDArray, B: NDArray) -> NDArray:
    """Capstan exponent ``phi[t, k, s, i]`` (paper Eq. (5) with the blocks).

    ``A``, ``B`` have shape (G, m) for ``m`` tendons (G = 1: tied); the constant law uses ``B`` as mu.
    """
    cos, scaled = terms.cos_alpha, terms.scaled
    m = B.shape[1]
    phi = np.empty(np.broadcast_shapes(cos.shape[:3], scaled.shape[:3], (1, B.shape[0], 1)) + (m,))
    # One tendon at a time, in place: calibration calls this thousands of times, and numpy's loops
    # over the long axes are several times faster than a broadcast whose innermost axis is m.
    for i in range(m):
        out = phi[..., i]
        sc = scaled[..., min(i, scaled.shape[3] - 1)]
        if mu_law == "constant":
            np.multiply(B[None, :, None, i], sc, out=out)
            continue
        np.multiply(A[None, :, None, i], cos[..., min(i, cos.shape[3] - 1)], out=out)
        out += B[None, :, None, i]
        out *= sc
    return phi


def log_entering(blocks: Sequence[Block], inputs, values: dict, sets: NDArray, tendons: NDArray) -> NDArray:
    """``ln T`` entering the chain, shape (T, S, m): the actuator-side readings through the ``actuator`` blocks.

    The blocks undo the measurement chain in reverse physical order (:attr:`Block.measurement_order`).
    Without one, the readings' logarithm is memoised per sets and tendons; with them, the last
    result is kept per sets and tendons with the block values it was computed at (calibration
    evaluates the chain thousands of times, often at the same block values).
    """
    key = f"log_in:{sets.tobytes().hex()}:{tendons.tobytes().hex()}"
    undo = sorted((b for b in blocks if b.acts_at("actuator")), key=lambda b: -b.measurement_order)
    if not undo:
        # The logarithm of only these sets and tendons: a calibration on terminal labels reads set N
        # alone, and the whole (T, N, n) logarithm would be half the recording again.
        return inputs.memo(key, lambda: np.log(inputs.actuator[:, sets][:, :, tendons]))
    state = repr([(b, sorted(values.get(b.name, {}).items())) for b in undo])
    last = inputs.cache.get("actuator_" + key)
    if last is None or last[0] != state:
        log_in = np.log(np.maximum(actuator_tension(blocks, inputs, values, sets, tendons), FLOOR_N))
        log_in.flags.writeable = False  # shared by the evaluations at these values
        last = (state, log_in)
        inputs.cache["actuator_" + key] = last  # one entry per sets and tendons: a fit does not fill memory
    return last[1]


def actuator_tension(blocks: Sequence[Block], inputs, values: dict, sets: NDArray, tendons: NDArray) -> NDArray:
    """The actuator-side tension [N], shape (T, S, m): the readings through the ``actuator`` blocks, if any.

    The blocks undo the measurement chain in reverse physical order (:attr:`Block.measurement_order`).
    """
    tension = inputs.actuator[:, sets][:, :, tendons]
    ctx = HookContext(inputs, sets, tendons)
    for b in sorted((b for b in blocks if b.acts_at("actuator")), key=lambda b: -b.measurement_order):
        tension = b.actuator(tension, ctx, values.get(b.name, {}))
    return tension


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
    log_in = log_entering(blocks, inputs, values, sets, tendons)  # (T, S, m)
    chain = np.full((inputs.n_frames, n) + log_in.shape[1:], np.nan) if keep_chain else None
    if keep_chain:
        chain[:, 0] = log_in
    edges = [b for b in blocks if b.stage == "edges"]
    prop = step_block(blocks)
    outputs = [b for b in blocks if b.stage == "guide_output"]
    start = next((b for b in blocks if b.stage == "start"), None)
    if prop is not None and not edges and not outputs:
        series = _series(prop, start, terms, phi, log_in, sets, values, keep_chain)
        if series is not None:
            final, guides = series
            if keep_chain:
                chain[:, 1:] = guides
            return chain if keep_chain else final
    if start is not None:
        raise ConfigError(
            f"the {start.name} block sets the state the compiled pass over the chain starts from; the "
            f"{prop.name if prop is not None else 'missing'} step has no such pass",
            param="blocks",
        )
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


def _series(
    prop: Block,
    start: Block | None,
    terms: ExponentTerms,
    phi: NDArray,
    log_t: NDArray,
    sets: NDArray,
    values: dict,
    keep: bool,
):
    """The whole chain from the step block's :meth:`~Block.propagate_series`, reshaped; None if it has none.

    A ``start`` block gives the share of each band every column restarts at.
    """
    t, s, m = log_t.shape
    k = phi.shape[1]
    n_pass = np.repeat(np.minimum(sets, k), m)  # set j (index j - 1) passes the guides k < j
    flat_phi = np.broadcast_to(phi, (t, k, s, m)).reshape(t, k, s * m)
    flat_in = log_t.reshape(t, s * m)
    share = None if start is None else start.start(flat_in, flat_phi, n_pass, terms.ctx, values.get(start.name, {}))
    out = prop.propagate_series(flat_in, flat_phi, n_pass, terms.ctx, values.get(prop.name, {}), keep, share)
    if out is None:
        return None
    final, chain = out
    return final.reshape(t, s, m), None if chain is None else chain.reshape(t, k, s, m)


def step_block(blocks: Sequence[Block]) -> Block | None:
    """The ``propagate`` block that sets a guide's step: one that refines another (a smooth edge), else the only one."""
    props = [b for b in blocks if b.stage == "propagate"]
    return next((b for b in props if b.requires), props[0] if props else None)


def apply_sensor(blocks: Sequence[Block], tension: NDArray, ctx: HookContext, values: dict) -> NDArray:
    """The sensor blocks on a predicted terminal reading [N], shape (T, m).

    In the physical order of a load cell's measurement chain (:attr:`Block.measurement_order`: the
    cell's lag, the instant it is sampled at, its calibration), each order's blocks in the model's.
    """
    for b in sorted((b for b in blocks if b.acts_at("sensor")), key=lambda b: b.measurement_order):
        tension = b.sensor(tension, ctx, values.get(b.name, {}))
    return tension
