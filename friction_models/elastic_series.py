"""Elastic tendons through guides in series, over a block of frames: many tendons in one compiled pass.

Each column is one tendon: an elastic chain through its first ``n_pass`` guides, solved frame by
frame with :func:`friction_models.elastic_chain.elastic_chain_frame` (the quasi-static
equilibrium of capstan bands and linear springs; Kaneko, Paetsch & Tolle 1992; Agrawal, Peine &
Yao 2010). It is the elastic counterpart of :func:`friction_models.kernels.play_series`, which is
its limit for segments whose path lengths do not change. The loop is compiled by numba where it
is installed (Lam, Pitrou & Seibert 2015), as :mod:`friction_models.kernels` is; without numba the
same frame function runs as Python, column by column, the reference.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from friction_models.elastic_chain import elastic_chain_frame

try:  # pragma: no cover - which branch runs depends on the install
    import numba
except ImportError:  # pragma: no cover
    numba = None

__all__ = ["elastic_series"]


def _series_loop(t_in, d_length, phi, n_pass, k, reset, start, floor, final, chain, keep):  # pragma: no cover
    # Column-major inputs: t_in and start (M, T), d_length and phi (M, T, K); state per column.
    m, n = t_in.shape
    kk = phi.shape[2]
    tension, branch, loss = np.zeros(kk), np.zeros(kk), np.zeros(kk)
    c, cp, em, ep = np.empty(kk), np.empty(kk), np.empty(kk), np.empty(kk)
    sigma = np.zeros(kk, dtype=np.int8)
    for j in range(m):
        g = n_pass[j]
        for t in range(n):
            if g == 0:
                final[t, j] = t_in[j, t]
                continue
            first = t == 0 or reset[t]
            elastic_chain_frame(
                t_in[j, t], tension[:g], branch[:g], d_length[j, t, :g], phi[j, t, :g], loss[:g], k[:g],
                first, 1.0, 0.0, floor, c[:g], cp[:g], em[:g], ep[:g], sigma[:g],
            )  # fmt: skip
            f = start[j, t]
            if first and f > 0.0:  # a restart at the share f of every band, as play_series starts
                x = t_in[j, t]
                for s in range(g):
                    x = max(x * math.exp((2.0 * f - 1.0) * phi[j, t, s]), floor)
                    tension[s] = x
                    sigma[s] = 0
            final[t, j] = tension[g - 1]
            if keep:
                for s in range(g):
                    chain[t, s, j] = tension[s]


if numba is not None:
    # The loop reads the frame function as a global when compiled: bind it to its compiled form.
    elastic_chain_frame = numba.njit(cache=True, inline="always")(elastic_chain_frame)
    _series_loop = numba.njit(cache=True, nogil=True)(_series_loop)


def elastic_series(
    t_in: NDArray,
    d_length: NDArray,
    phi: NDArray,
    n_pass: NDArray,
    stiffness: NDArray,
    reset: NDArray,
    *,
    floor: float = 1e-3,
    keep_chain: bool = False,
    start: NDArray | None = None,
) -> tuple[NDArray[np.float64], NDArray[np.float64] | None]:
    """Tensions leaving each tendon's last guide, every tendon an elastic chain (purely elastic, no lag).

    Parameters
    ----------
    t_in : ndarray, shape (T, M)
        Actuator tension of each column [N], ``> 0``.
    d_length : ndarray, shape (T, K, M)
        Change of each segment's path length since the frame before [m]; segment ``g`` follows
        guide ``g`` (ignored on resets).
    phi : ndarray, shape (T, K, M)
        Capstan exponent of each guide ``>= 0`` [-].
    n_pass : ndarray of int, shape (M,)
        How many guides each column passes (``<= K``).
    stiffness : ndarray, shape (K,)
        ``EA / l`` of each segment [N/m], ``> 0``.
    reset : ndarray of bool, shape (T,)
        Trajectory starts: the tendon starts taut from the actuator (every guide on its
        forward-slip edge).
    floor : float
        Lowest tension a band's lower edge reaches [N].
    keep_chain : bool
        Also return every segment's tension.
    start : ndarray, shape (T, M), optional
        Share ``f`` in ``[0, 1]`` of each guide's band a column restarts at, read at restarts only:
        segment ``s`` at ``T_{s-1} e^{(2 f - 1) phi_s}`` (default 0: taut, every guide on its
        forward-slip edge), as :func:`friction_models.kernels.play_series` restarts.

    Returns
    -------
    final : ndarray, shape (T, M)
        Tension of each column's last segment, the joint side [N] (``t_in`` where it passes none).
    chain : ndarray, shape (T, K, M), or None
        Tension of segment ``g`` in ``chain[:, g]`` [N], NaN beyond a column's last guide.
    """
    t_in = np.asarray(t_in, dtype=float)
    n, m = t_in.shape
    kk = phi.shape[1]
    n_pass = np.minimum(np.asarray(n_pass, dtype=np.int64), kk)
    reset = np.ascontiguousarray(reset, dtype=np.bool_)
    k = np.ascontiguousarray(np.broadcast_to(np.asarray(stiffness, dtype=float), (kk,)))
    # Column-major copies, so that each column's frames are contiguous in the loop.
    cols_in = np.ascontiguousarray(t_in.T)
    cols_dl = np.ascontiguousarray(np.broadcast_to(d_length, (n, kk, m)).transpose(2, 0, 1))
    cols_phi = np.ascontiguousarray(np.broadcast_to(phi, (n, kk, m)).transpose(2, 0, 1))
    cols_start = (
        np.zeros((m, n)) if start is None else np.ascontiguousarray(np.broadcast_to(start, (n, m)).T, dtype=float)
    )
    final = np.empty((n, m))
    chain = np.full((n, kk, m), np.nan) if keep_chain else np.empty((1, 1, 1))
    _series_loop(cols_in, cols_dl, cols_phi, n_pass, k, reset, cols_start, float(floor), final, chain, bool(keep_chain))
    return final, chain if keep_chain else None
