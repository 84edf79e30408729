"""The robot's statics: every tendon that crosses a joint pulls on it, and gravity (:doc:`/guide/closed_loop`).

Cut the robot across joint ``k``: every tendon that crosses the cut (sets ``j >= k``) pulls on
the distal part.  By virtual work the generalised moment about joint ``k``'s two axes is::

    tau_k = - sum_{j >= k} sum_i T[k, j, i] dl_kji / dtheta_k

with ``l_kji`` the length of tendon ``i`` of set ``j`` across joint ``k``, hole to hole
(:func:`tendon_id.geometry.crossing_length`, the same hole positions the transmission's wraps
come from), and ``T[k, j, i]`` its tension there.  To first order ``dl/dtheta = -r (cos psi,
sin psi)`` and the moment is ``r sum T u``; the exact derivative adds the tendons' geometric
stiffness, which tensioned tendons through holes ``h`` from a pivot give.

Gravity's generalised moment is ``sum_m m_m g . dq_m/dtheta_k`` over the masses distal to the
joint; a point rigid with the links beyond joint ``k`` moves as ``dq = w x (q - p_k)`` with ``w``
the axis of the joint's coordinate and ``p_k`` its pivot (Featherstone, *Rigid Body Dynamics
Algorithms*, Springer 2008, §2.4), so ``tau = w . sum_m (q_m - p_k) x m_m g``.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from tendon_id.geometry import RobotGeometry, joint_rotation, own_bend, tendon_azimuths
from tendon_id.sim.body import Body

__all__ = [
    "composite_inertia",
    "crossing_jacobian",
    "elastic_energy",
    "elastic_return",
    "gravity_moments",
    "link_frames",
    "on_path",
    "tendon_moments",
]


def on_path(n_modules: int) -> NDArray[np.bool_]:
    """``[k, j]``: whether the tendons of set ``j`` cross joint ``k`` (``k <= j``), shape (N, N)."""
    k = np.arange(n_modules)
    return k[:, None] <= k[None, :]


def _rotation_derivatives(theta: NDArray) -> tuple[NDArray, NDArray]:
    """``dR/dtheta_x`` and ``dR/dtheta_y`` of :func:`~tendon_id.geometry.joint_rotation`, shape (..., 3, 3)."""
    a, b = theta[..., 0], theta[..., 1]
    ca, sa, cb, sb = np.cos(a), np.sin(a), np.cos(b), np.sin(b)
    z = np.zeros_like(a)
    # R = R_y(a) R_x(-b) multiplied out (geometry.joint_rotation), each entry differentiated.
    da = np.stack([-sa, -ca * sb, ca * cb, z, z, z, -ca, sa * sb, -sa * cb], axis=-1)
    db = np.stack([z, -sa * cb, -sa * sb, z, -sb, cb, z, -ca * cb, -ca * sb], axis=-1)
    return da.reshape(a.shape + (3, 3)), db.reshape(a.shape + (3, 3))


def crossing_jacobian(theta: NDArray, geometry: RobotGeometry) -> NDArray[np.float64]:
    """``dl_kji / dtheta_k`` [m/rad] of every tendon across every joint it crosses, shape (..., N, N, n, 2).

    ``[..., k, j, i, :]``: the segment of tendon ``i`` of set ``j`` across joint ``k`` (0-based),
    zero where the set does not cross the joint (``k > j``).  The segment is ``s = R (u + h e_z) -
    (u - h e_z)`` (``u`` the hole's position on the disk, ``h`` half the joint gap), so
    ``dl/dtheta = s . (dR/dtheta (u + h e_z)) / |s|``.  ``n`` is the robot's tendons per set.
    """
    theta = np.asarray(theta, dtype=float)
    n = geometry.n_modules
    psi = tendon_azimuths(geometry)  # (N sets, n tendons)
    r, h = geometry.hole_radius, 0.5 * geometry.joint_gap
    ux, uy = r * np.cos(psi), r * np.sin(psi)
    R = joint_rotation(theta)[..., :, None, None, :, :]  # (..., N joints, 1, 1, 3, 3)
    sx = R[..., 0, 0] * ux + R[..., 0, 1] * uy + R[..., 0, 2] * h - ux
    sy = R[..., 1, 0] * ux + R[..., 1, 1] * uy + R[..., 1, 2] * h - uy
    sz = R[..., 2, 0] * ux + R[..., 2, 1] * uy + R[..., 2, 2] * h + h
    length = np.sqrt(sx * sx + sy * sy + sz * sz)
    out = np.empty(length.shape + (2,))
    for axis, dR in enumerate(_rotation_derivatives(theta)):
        dR = dR[..., :, None, None, :, :]
        dx = dR[..., 0, 0] * ux + dR[..., 0, 1] * uy + dR[..., 0, 2] * h
        dy = dR[..., 1, 0] * ux + dR[..., 1, 1] * uy + dR[..., 1, 2] * h
        dz = dR[..., 2, 0] * ux + dR[..., 2, 1] * uy + dR[..., 2, 2] * h
        out[..., axis] = (sx * dx + sy * dy + sz * dz) / length
    return out * on_path(n)[:, :, None, None]


def tendon_moments(chain: NDArray, jacobian: NDArray) -> NDArray[np.float64]:
    """Moment of every tendon crossing each joint [N m], shape (..., N, 2).

    Parameters
    ----------
    chain : ndarray, shape (..., N, N, n)
        ``T[k, j, i]`` [N], the tension of tendon ``i`` of set ``j`` across joint ``k``; entries off
        the path (``k > j``, NaN in a model's ``predict_chain``) are not read.
    jacobian : ndarray, shape (..., N, N, n, 2)
        :func:`crossing_jacobian`.
    """
    chain = np.where(on_path(chain.shape[-2])[:, :, None], chain, 0.0)
    return -np.einsum("...kji,...kjia->...ka", chain, jacobian)


def link_frames(theta: NDArray, geometry: RobotGeometry) -> tuple[NDArray, NDArray]:
    """Orientation and pivot of every link in the base's frame.

    Link ``k``'s frame sits at joint ``k``'s pivot, turned by joints ``1..k``; its holes lie ``h``
    above the pivot and its top ``h + link_length`` above; the next pivot is one pitch
    (``link_length + joint_gap``) up.

    Returns
    -------
    rotation : ndarray, shape (..., N, 3, 3)
    pivot : ndarray, shape (..., N, 3) [m]
    """
    theta = np.asarray(theta, dtype=float)
    n = geometry.n_modules
    joint = joint_rotation(theta)
    rot = np.empty(joint.shape)
    piv = np.zeros(theta.shape[:-1] + (3,))
    pitch = geometry.link_length + geometry.joint_gap
    current = np.broadcast_to(np.eye(3), joint.shape[:-3] + (3, 3))
    for k in range(n):  # the chain's one sequential axis
        current = current @ joint[..., k, :, :]
        rot[..., k, :, :] = current
        if k + 1 < n:
            piv[..., k + 1, :] = piv[..., k, :] + pitch * current[..., :, 2]
    return rot, piv


def gravity_moments(theta: NDArray, geometry: RobotGeometry, body: Body) -> NDArray[np.float64]:
    """Gravity's generalised moment about each joint's two axes [N m], shape (..., N, 2).

    Each link's mass sits half-way along it, the payload at the last link's top.  Zero when
    ``body.gravity`` is off.
    """
    theta = np.asarray(theta, dtype=float)
    g = body.gravity_in_base()
    if not g.any():
        return np.zeros(theta.shape)
    rot, piv = link_frames(theta, geometry)
    h = 0.5 * geometry.joint_gap
    centre = piv + (h + 0.5 * geometry.link_length) * rot[..., :, 2]
    # Moment of every mass distal to joint k about the base's origin, summed from the tip: M_k = sum q x m g.
    force = body.link_mass_kg * g
    about_origin = np.cumsum(np.cross(centre, force)[..., ::-1, :], axis=-2)[..., ::-1, :]
    mass_beyond = body.link_mass_kg * np.arange(geometry.n_modules, 0, -1)[:, None] * g
    if body.payload_kg:
        tip = piv[..., -1, :] + (h + geometry.link_length) * rot[..., -1, :, 2]
        about_origin = about_origin + np.cross(tip, body.payload_kg * g)[..., None, :]
        mass_beyond = mass_beyond + body.payload_kg * g
    moment = about_origin - np.cross(piv, mass_beyond)  # about each pivot: sum (q - p_k) x m g
    # The axes of joint k's coordinates: w_x = R_{k-1} e_y and w_y = -R_{k-1} R_y(theta_x) e_x (joint_rotation).
    before = np.concatenate([np.broadcast_to(np.eye(3), rot.shape[:-3] + (1, 3, 3)), rot[..., :-1, :, :]], axis=-3)
    a = theta[..., 0]
    ry_ex = np.stack([np.cos(a), np.zeros_like(a), -np.sin(a)], axis=-1)
    w_x = before[..., :, 1]
    w_y = -np.einsum("...ij,...j->...i", before, ry_ex)
    return np.stack([np.sum(w_x * moment, axis=-1), np.sum(w_y * moment, axis=-1)], axis=-1)


def composite_inertia(geometry: RobotGeometry, body: Body) -> NDArray[np.float64]:
    """Moment of inertia [kg m^2] of the chain distal to each joint about its bending axes, straight, shape (N,).

    The diagonal of the joint-space inertia matrix at the straight pose, the composite-rigid-body
    inertia (Featherstone 2008, §6.2): each link a thin-walled tube of its mass (``m (L^2/12 +
    R^2/2)`` about a transverse axis through its centre, R its outer radius) moved by the
    parallel-axis theorem, and the payload a point.  The off-diagonal couplings are left out:
    the plant is one second-order system per joint.
    """
    n = geometry.n_modules
    pitch = geometry.link_length + geometry.joint_gap
    h, length = 0.5 * geometry.joint_gap, geometry.link_length
    m = body.link_mass_kg
    own = m * (length**2 / 12.0 + body.link_radius_m**2 / 2.0)
    out = np.empty(n)
    for k in range(n):
        d = (np.arange(k, n) - k) * pitch + h + 0.5 * length  # pivot k to each distal link's centre
        tip = (n - 1 - k) * pitch + h + length
        out[k] = np.sum(own + m * d**2) + body.payload_kg * tip**2
    return out


def elastic_return(theta: NDArray, psi: NDArray, gain_n_per_rad: float, hole_radius: float) -> NDArray[np.float64]:
    """The joints' elastic return [N m], shape (..., N, 2): the moment the open-loop actuation assumes holds a bend.

    The simulator's actuation (:class:`tendon_id.sim.actuation.Actuation`) holds joint ``j`` at
    ``theta_j`` with its own set's puller share ``g [b_ji]_+``, ``b_ji = theta_j . u_ji``, so the
    joint must return ``r g sum_i [theta . u_i]_+ u_i``: stiffness ``g r`` towards a tendon, half
    that between two.  It is the gradient of :func:`elastic_energy`, so it is conservative.
    """
    u = np.stack([np.cos(psi), np.sin(psi)], axis=-1)  # (N, n, 2)
    return -hole_radius * gain_n_per_rad * np.einsum("...ki,kia->...ka", np.maximum(own_bend(theta, psi), 0.0), u)


def elastic_energy(theta: NDArray, psi: NDArray, gain_n_per_rad: float, hole_radius: float) -> NDArray[np.float64]:
    """Energy [J] stored by :func:`elastic_return`, ``(g r / 2) sum_k sum_i [b_ki]_+^2``, shape (...)."""
    return 0.5 * hole_radius * gain_n_per_rad * np.sum(np.maximum(own_bend(theta, psi), 0.0) ** 2, axis=(-2, -1))
