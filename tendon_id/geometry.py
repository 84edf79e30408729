"""Robot geometry: tendon routing, wrap angles and the contact gate (:doc:`/guide/geometry`).

Conventions
-----------
* ``theta`` has shape ``(T, N, 2)``: ``theta[:, k-1] = (theta_k_x, theta_k_y)`` [rad],
  the bend of joint ``k`` towards the disk's +x and +y directions.
* Guide ``k`` (``k = 1..N-1``) is the bore of link ``k``, between joint ``k`` and
  joint ``k + 1``.  The tendons of set ``j`` pass guides ``1..j-1``.
* Tendon ``i`` (``i = 1..n``, ``n = n_tendons``) of set ``j`` runs at azimuth ``psi[j-1, i-1]``
  on every disk (:func:`tendon_azimuths`).  A robot is described in a robot file
  (:mod:`tendon_id.robot_file`).

The paper's ``Geom(q_k)`` (Eq. (3)) is :func:`backbone_wrap`: one wrap per guide,
shared by every tendon.  :func:`exact_wrap` is the forward kinematics of the hole points,
which the simulator's ``per_tendon_wrap`` effect uses, and :func:`projected_wrap` its expansion
to second order in the bends (:doc:`/guide/geometry`).

``RobotGeometry.alpha_0`` and ``alpha_c`` are the simulator's truth: a user does not know a
robot's routing wrap or clearance angle, so no model reads them; the capstan models fit both
(:mod:`tendon_id.zoo.blocks.geometric`).  How fast a tendon slides through a guide as the
joints move is :mod:`tendon_id.sliding`.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from friction_models import hard_contact_gate, smooth_contact_gate
from tendon_id.robot import MEASURED, RobotGeometry, si_description, tendon_azimuths

__all__ = [
    "MEASURED",
    "RobotGeometry",
    "backbone_wrap",
    "contact_gate",
    "exact_wrap",
    "joint_rotation",
    "own_bend",
    "projected_bend",
    "projected_wrap",
    "si_description",
    "sin_q",
    "tendon_azimuths",
    "turn_into_upper",
    "turn_out_of_lower",
]


def projected_bend(theta: ArrayLike, psi: ArrayLike) -> NDArray[np.float64]:
    """Bend of each joint projected on a tendon azimuth: ``b = theta_x cos psi + theta_y sin psi``.

    Parameters
    ----------
    theta : array_like, shape (..., N, 2)
        Joint angles [rad].
    psi : array_like, shape (S, 3)
        Azimuths [rad] of S tendon sets.

    Returns
    -------
    ndarray, shape (..., N, S, 3)
        Projected bend [rad]; also ``-1/r`` times the tendon's length change per
        joint for holes at radius ``r`` (small angles).
    """
    theta = np.asarray(theta, dtype=float)
    psi = np.asarray(psi, dtype=float)
    return theta[..., :, None, None, 0] * np.cos(psi) + theta[..., :, None, None, 1] * np.sin(psi)


def own_bend(theta: ArrayLike, psi: ArrayLike) -> NDArray[np.float64]:
    """Each joint's bend projected on its own set's tendons, ``b_ki = theta_k . (cos psi_ki, sin psi_ki)`` [rad].

    The diagonal of :func:`projected_bend` (joint ``k``, set ``k``), without forming the rest.

    Parameters
    ----------
    theta : array_like, shape (..., N, 2)
        Joint angles [rad].
    psi : array_like, shape (N, 3)
        Azimuths [rad] of the N sets.

    Returns
    -------
    ndarray, shape (..., N, 3)
    """
    theta = np.asarray(theta, dtype=float)
    psi = np.asarray(psi, dtype=float)
    return theta[..., :, 0, None] * np.cos(psi) + theta[..., :, 1, None] * np.sin(psi)


def backbone_wrap(theta: ArrayLike, alpha_0: float) -> NDArray[np.float64]:
    """Backbone-level wrap per guide, the paper's ``alpha_k = Geom(q_k)`` (Eq. (3)).

    ``alpha_k = |theta_k| / 2 + |theta_{k+1}| / 2 + alpha_0``: at each joint it
    crosses, the tendon turns by half the joint's bend (:doc:`/guide/geometry`).

    Parameters
    ----------
    theta : array_like, shape (..., N, 2)
        Joint angles [rad].
    alpha_0 : float
        Routing wrap [rad].

    Returns
    -------
    ndarray, shape (..., N-1)
        Wrap of guides ``1..N-1`` [rad], in ``[alpha_0, pi]``.
    """
    mag = np.linalg.norm(np.asarray(theta, dtype=float), axis=-1)
    return np.minimum(0.5 * mag[..., :-1] + 0.5 * mag[..., 1:] + alpha_0, np.pi)


def sin_q(theta: ArrayLike) -> NDArray[np.float64]:
    """The unit's joint inputs ``sin(q_k)`` with ``q_k = (theta_k, theta_{k+1})`` (paper Eq. (2), Eq. (7)).

    Parameters
    ----------
    theta : array_like, shape (..., N, 2)
        Joint angles [rad].

    Returns
    -------
    ndarray, shape (..., N-1, 4)
        ``[sin theta_k, sin theta_{k+1}]`` per guide ``k = 1..N-1`` (dimensionless).
    """
    s = np.sin(theta)
    return np.concatenate([s[..., :-1, :], s[..., 1:, :]], axis=-1)


def projected_wrap(
    theta: ArrayLike, geometry: RobotGeometry, psi: ArrayLike | None = None, *, alpha_0: float | None = None
) -> NDArray[np.float64]:
    """Per-tendon wrap to second order in the bends: :func:`exact_wrap` expanded (:doc:`/guide/geometry`).

    For small bends of the Cardan joint (hole radius ``r``, hole planes ``h = joint_gap / 2``
    from the pivot) the turn out of the lower link is ``|theta| / 2 + d`` and the turn into the
    upper one ``|theta| / 2 - d``, with ``d = r theta_x theta_y b(psi + pi/2) / (4 h |theta|)``
    and ``b`` the projected bend (:func:`projected_bend`): to first order every tendon turns by
    half the bend whatever its azimuth (the backbone wrap), and ``d`` is the Cardan twist
    ``theta_x theta_y / 2`` moving the upper hole sideways.  The error is ``O(|theta|^3)``.

    Parameters
    ----------
    theta : array_like, shape (..., N, 2)
        Joint angles [rad].
    geometry : RobotGeometry
        Hole radius and joint gap.
    psi : array_like, shape (S, 3), optional
        Azimuths [rad]; default :func:`tendon_azimuths`.
    alpha_0 : float, optional
        Routing wrap [rad]; default ``geometry.alpha_0``, the simulator's truth (a model passes 0).

    Returns
    -------
    ndarray, shape (..., N-1, S, 3)
        Wrap [rad] of guide ``k`` for tendon ``i`` of set ``j``, at most pi.
    """
    theta = np.asarray(theta, dtype=float)
    psi = tendon_azimuths(geometry) if psi is None else np.asarray(psi, dtype=float)
    tx, ty = theta[..., 0, None, None], theta[..., 1, None, None]
    mag = np.hypot(tx, ty)
    scaled = geometry.hole_radius / (2.0 * geometry.joint_gap) * tx * ty * projected_bend(theta, psi + 0.5 * np.pi)
    d = np.divide(scaled, mag, out=np.zeros(scaled.shape), where=mag > 0)  # the numerator is O(|theta|^3)
    a0 = geometry.alpha_0 if alpha_0 is None else float(alpha_0)
    # Guide k: the turn into link k at joint k, and out of it at joint k + 1.
    into_upper = 0.5 * mag[..., :-1, :, :] - d[..., :-1, :, :]
    out_of_lower = 0.5 * mag[..., 1:, :, :] + d[..., 1:, :, :]
    return np.minimum(into_upper + out_of_lower + a0, np.pi)


def joint_rotation(theta: ArrayLike) -> NDArray[np.float64]:
    """Rotation of a Cardan (universal) joint, upper link relative to lower link.

    ``R = R_y(theta_x) R_x(-theta_y)``: the first cross axis bends towards +x,
    the second towards +y.  A Cardan joint twists the upper link slightly when
    both axes move, which is what makes the exact wraps differ per tendon.

    Parameters
    ----------
    theta : array_like, shape (..., 2)
        ``(theta_x, theta_y)`` [rad].

    Returns
    -------
    ndarray, shape (..., 3, 3)
    """
    theta = np.asarray(theta, dtype=float)
    a, b = theta[..., 0], theta[..., 1]
    ca, sa, cb, sb = np.cos(a), np.sin(a), np.cos(b), np.sin(b)
    # R_y(a) @ R_x(-b), multiplied out.
    R = np.empty(theta.shape[:-1] + (3, 3))
    R[..., 0, 0] = ca
    R[..., 0, 1] = -sa * sb
    R[..., 0, 2] = sa * cb
    R[..., 1, 0] = 0.0
    R[..., 1, 1] = cb
    R[..., 1, 2] = sb
    R[..., 2, 0] = -sa
    R[..., 2, 1] = -ca * sb
    R[..., 2, 2] = ca * cb
    return R


def turn_out_of_lower(R: NDArray, ux: NDArray, uy: NDArray, h: float) -> NDArray:
    """Turn [rad] at a lower link's top hole: the segment across the joint against e_z.

    The segment in the lower link's frame is ``R (u + h e_z) - (u - h e_z)``, written out
    per component (an einsum over a trailing xyz axis is several times slower).
    """
    sx = R[..., 0, 0] * ux + R[..., 0, 1] * uy + R[..., 0, 2] * h - ux
    sy = R[..., 1, 0] * ux + R[..., 1, 1] * uy + R[..., 1, 2] * h - uy
    sz = R[..., 2, 0] * ux + R[..., 2, 1] * uy + R[..., 2, 2] * h + h
    return np.arctan2(np.hypot(sx, sy), sz)


def crossing_length(R: NDArray, ux: NDArray, uy: NDArray, h: float) -> NDArray:
    """Length [m] of a tendon's straight segment across a joint, from hole to hole.

    The segment ``R (u + h e_z) - (u - h e_z)`` of :func:`turn_out_of_lower` (``h`` is half the
    joint gap); ``2 h`` when straight, and ``2 h - r b(psi)`` to first order in the bend, the
    change ``dl = -r b`` of :doc:`/guide/geometry`.
    """
    sx = R[..., 0, 0] * ux + R[..., 0, 1] * uy + R[..., 0, 2] * h - ux
    sy = R[..., 1, 0] * ux + R[..., 1, 1] * uy + R[..., 1, 2] * h - uy
    sz = R[..., 2, 0] * ux + R[..., 2, 1] * uy + R[..., 2, 2] * h + h
    return np.sqrt(sx * sx + sy * sy + sz * sz)


def turn_into_upper(R: NDArray, ux: NDArray, uy: NDArray, h: float) -> NDArray:
    """Turn [rad] at an upper link's bottom hole: the segment seen from the upper link.

    ``R^T s = (u + h e_z) - R^T (u - h e_z)`` against e_z; atan2 of components keeps tiny
    turns exact, where ``|s|^2 - (s . a)^2`` would cancel.
    """
    vx = ux - (R[..., 0, 0] * ux + R[..., 1, 0] * uy - R[..., 2, 0] * h)
    vy = uy - (R[..., 0, 1] * ux + R[..., 1, 1] * uy - R[..., 2, 1] * h)
    vz = h - (R[..., 0, 2] * ux + R[..., 1, 2] * uy - R[..., 2, 2] * h)
    return np.arctan2(np.hypot(vx, vy), vz)


def exact_wrap(
    theta: ArrayLike,
    geometry: RobotGeometry,
    psi: ArrayLike | None = None,
    *,
    on_path_only: bool = False,
    alpha_0: float | None = None,
) -> NDArray[np.float64]:
    """Per-tendon wrap from the forward kinematics of the hole points.

    Across joint ``k`` the tendon runs straight from its hole in the top disk
    of link ``k-1`` to its hole in the bottom disk of link ``k``; inside a link it
    runs along the link's axis.  The turn at a hole is the angle between the
    consecutive segments, and guide ``k`` collects the turns at both ends of
    link ``k`` (from joints ``k`` and ``k+1``), plus the routing wrap ``alpha_0``.
    For a bend about one Cardan axis this reduces to :func:`backbone_wrap`; the
    Cardan twist of :func:`joint_rotation` spreads the turns unevenly over tendons.

    Parameters
    ----------
    theta : array_like, shape (T, N, 2)
        Joint angles [rad].
    geometry : RobotGeometry
        Hole radius and joint gap.
    psi : array_like, shape (S, 3), optional
        Azimuths; default :func:`tendon_azimuths`.
    on_path_only : bool
        Compute only where set ``j`` passes guide ``k`` (``k < j``, needs
        ``S = N``) and leave NaN elsewhere: half the work, for the simulator.
    alpha_0 : float, optional
        Routing wrap [rad]; default ``geometry.alpha_0`` (the simulator's truth; a model passes 0
        and adds its fitted routing wrap).

    Returns
    -------
    ndarray, shape (T, N-1, S, 3)
        Wrap [rad].
    """
    theta = np.asarray(theta, dtype=float)
    psi = tendon_azimuths(geometry) if psi is None else np.asarray(psi, dtype=float)
    a0 = geometry.alpha_0 if alpha_0 is None else float(alpha_0)
    rho, h = geometry.hole_radius, 0.5 * geometry.joint_gap
    ux, uy = rho * np.cos(psi), rho * np.sin(psi)  # hole offsets in the disk plane, (S, 3)
    R = joint_rotation(theta)  # (T, N, 3, 3)
    n = theta.shape[1]
    if not on_path_only:
        Rb = R[:, :, None, None]  # broadcast over the (S, 3) tendons
        into_upper, out_of_lower = turn_into_upper(Rb, ux, uy, h), turn_out_of_lower(Rb, ux, uy, h)
        # Guide k = link k: its bottom hole turns at joint k, its top hole at joint k+1.
        return np.minimum(into_upper[:, :-1] + out_of_lower[:, 1:] + a0, np.pi)
    if psi.shape[0] != n:
        raise ValueError("on_path_only needs one row of azimuths per set (S = N)")
    k, j = np.nonzero(np.arange(1, n)[:, None] < np.arange(1, n + 1)[None, :])  # guide index k-1, set index j-1
    ux_p, uy_p = ux[j], uy[j]  # (P, 3)
    into_upper = turn_into_upper(R[:, k, None], ux_p, uy_p, h)  # at joint k
    out_of_lower = turn_out_of_lower(R[:, k + 1, None], ux_p, uy_p, h)  # at joint k+1
    wrap = np.full((theta.shape[0], n - 1, n, 3), np.nan)
    wrap[:, k, j] = np.minimum(into_upper + out_of_lower + a0, np.pi)
    return wrap


def contact_gate(alpha: ArrayLike, geometry: RobotGeometry, *, smooth: bool = False, width: float = 0.01) -> NDArray:
    """Contact gate ``beta_k`` for the hole clearance of ``geometry`` (:doc:`/guide/geometry`).

    Parameters
    ----------
    alpha : array_like
        Wrap [rad].
    geometry : RobotGeometry
        Supplies the clearance angle ``alpha_c``.
    smooth : bool
        Use the differentiable sigmoid gate instead of the indicator.
    width : float
        Sigmoid width [rad] when ``smooth``.
    """
    if smooth:
        return smooth_contact_gate(alpha, geometry.alpha_c, width)
    return hard_contact_gate(alpha, geometry.alpha_c)
