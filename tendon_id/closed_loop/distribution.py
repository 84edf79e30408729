"""The tension distribution: a desired joint moment as tensions of the set's ``n`` tendons, none below a floor.

A set's ``n`` tendons run through holes at azimuths ``psi_i`` on a circle of radius ``r``.  At small
bends tendon ``i`` pulls its joint with the moment ``r T_i u_i``, ``u_i = (cos psi_i, sin psi_i)``
(the straight robot's tendon Jacobian, :func:`~tendon_id.closed_loop.statics.crossing_jacobian`), so
a set exerts ``A T`` with ``A = r [u_1 ... u_n]``, a 2 x n matrix (1 x n for a planar robot, whose
hinge only takes the moment about its y axis, the first row: the bearing reacts the other).  The
controller asks for the tensions that exert a desired moment ``M`` with every tendon taut, at least
at the pretension ``P`` (the puller-follower scheme of the paper's [3]: the follower keeps the tendon
taut).  Write ``T = P 1 + t``; the rule is the minimum-norm tension above the floor::

    minimise |t|^2   subject to   A t = M - P A 1,   t >= 0                      (1)

a strictly convex quadratic programme (Boyd and Vandenberghe, *Convex Optimization*, Cambridge
2004, §5.5.3, for its optimality conditions), feasible for every ``M`` when the set's directions
positively span the moment space (no half-plane holds them all: the set can pull every way).  Its
KKT conditions give ``t = [A^T lambda]_+`` for one ``lambda`` (``lambda`` the constraint's
multiplier): the tendons that pull are those within 90 deg of ``lambda``'s direction, each in
proportion to the cosine, and ``t_S = A_S^+ b`` on that active set ``S``, the pseudo-inverse's
minimum-norm solution.  As ``lambda`` turns, ``S`` changes only where ``lambda`` crosses a
direction normal to a tendon, so at most ``2 n`` active sets are candidates; the solution is the
candidate that is feasible (``t_S >= 0``, ``A t = b``) with the least norm, exactly (every
feasible candidate is a feasible point of (1), and the optimum is one of them).

**The closed form.**  When the set's null space is the common mode alone and the common mode exerts
no moment (``n = m + 1`` tendons with ``A 1 = 0``, ``m`` the bending axes: three tendons 120 deg
apart, the paper's, or an antagonistic pair), (1) is ``t = d + c 1`` with ``d = A^+ M`` (which sums
to zero, being orthogonal to the null space), ``|t|^2 = |d|^2 + n c^2``, least at the smallest
feasible ``c = -min_i d_i``::

    T_i = P + d_i - min_l d_l                                                      (2)

For three tendons 120 deg apart ``A A^T = (3/2) r^2 I``, so ``d_i = 2 / (3 r) M . u_i``: the rule the
controller always used, computed in the same operations, so the paper robot's closed loop is
unchanged to the bit.  With more tendons than that the null space is larger and (2) is not the
optimum: for four tendons at 90 deg it would pull both tendons of a pair above the floor, where (1)
leaves one of each pair at ``P`` (each pair's puller-follower).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from tendon_id.errors import ConfigError

__all__ = ["TensionDistribution", "tension_distribution"]

#: Relative tolerance of the candidates' feasibility checks: far above the rounding of a 2 x n pseudo-inverse.
_RTOL = 1e-9


def _active_sets(psi: NDArray, axes: int) -> NDArray[np.bool_]:
    """The candidate active sets of one set's tendons, shape (C, n): those within 90 deg of a direction ``lambda``.

    ``axes`` 2: one per arc between consecutive directions normal to a tendon (``psi_i +- 90 deg``),
    taken at its middle; ``axes`` 1: ``lambda`` along +x or -x.
    """
    if axes == 1:
        c = np.cos(psi)
        return np.unique(np.stack([c > 0, c < 0]), axis=0)
    normals = np.sort(np.mod(np.concatenate([psi + 0.5 * np.pi, psi - 0.5 * np.pi]), 2.0 * np.pi))
    middles = 0.5 * (normals + np.append(normals[1:], normals[0] + 2.0 * np.pi))
    return np.unique(np.cos(middles[:, None] - psi[None, :]) > 0, axis=0)


def _check_spans(psi: NDArray, axes: int, k: int) -> None:
    """Refuse a set that cannot pull every way: (1) would have no solution for some moments."""
    if axes == 1:
        c = np.cos(psi)
        ok = c.max() > 1e-9 and c.min() < -1e-9
    else:  # every gap between consecutive azimuths below 180 deg
        s = np.sort(np.mod(psi, 2.0 * np.pi))
        ok = np.diff(np.append(s, s[0] + 2.0 * np.pi)).max() < np.pi - 1e-9
    if not ok:
        raise ConfigError(
            f"tendon set {k + 1} cannot exert every {'moment about its hinge' if axes == 1 else 'bending moment'}: "
            f"its tendons at {np.round(np.rad2deg(psi), 3).tolist()} deg all lie on one side of the joint"
        )


class TensionDistribution:
    """The rule (1) of :mod:`this module <tendon_id.closed_loop.distribution>` for every set of a robot.

    Parameters
    ----------
    psi : ndarray, shape (N, n)
        Tendon azimuths [rad] of the ``N`` sets.
    hole_radius : float
        Moment arm ``r`` [m].
    pretension : float
        The floor ``P`` [N]: the slackest tendon's tension.
    bending_axes : int
        2 (Cardan joints: the moment ``(M_x, M_y)``) or 1 (hinges: ``M_x`` alone, the moment about the
        joint's y axis that bends ``theta_x``; the desired ``M_y`` is not read).

    Raises
    ------
    ConfigError
        If a set's tendons cannot exert every moment (all on one side of the joint).
    """

    def __init__(self, psi: NDArray, hole_radius: float, pretension: float, bending_axes: int = 2):
        self.psi = np.atleast_2d(np.asarray(psi, dtype=float))
        self.hole_radius, self.pretension, self.axes = float(hole_radius), float(pretension), int(bending_axes)
        if self.axes not in (1, 2):
            raise ConfigError(f"bending_axes must be 1 or 2, got {bending_axes!r}")
        n_sets, n = self.psi.shape
        for k in range(n_sets):
            _check_spans(self.psi[k], self.axes, k)
        self.A = self.hole_radius * np.stack([np.cos(self.psi), np.sin(self.psi)], axis=1)[:, : self.axes]  # (N, m, n)
        # (2) applies where the null space is the common mode (n = m + 1) and it exerts no moment.
        balanced = np.abs(self.A.sum(axis=-1)).max(axis=-1) <= _RTOL * self.hole_radius
        self.closed_form = n == self.axes + 1 and bool(balanced.all())
        if self.closed_form:
            return
        # Each candidate's pseudo-inverse, zero outside its active set; a set with fewer candidates repeats its last.
        sets = [_active_sets(self.psi[k], self.axes) for k in range(n_sets)]
        c_max = max(len(s) for s in sets)
        self.pinv = np.zeros((n_sets, c_max, n, self.axes))
        for k, cand in enumerate(sets):
            for c in range(c_max):
                on = cand[min(c, len(cand) - 1)]
                self.pinv[k, c, on] = np.linalg.pinv(self.A[k][:, on])

    def __call__(self, torque: NDArray, sets: slice | None = None) -> NDArray[np.float64]:
        """Tensions [N], shape (..., S, n), that exert ``torque`` [N m], shape (..., S, 2), on sets ``sets``.

        ``sets`` selects the rows of ``psi`` the torques are for (default: all ``N``).
        """
        sets = slice(None) if sets is None else sets
        torque = np.asarray(torque, dtype=float)
        if self.closed_form:
            return self._closed(torque, sets)
        A, pinv = self.A[sets], self.pinv[sets]
        b = torque[..., : self.axes] - self.pretension * A.sum(axis=-1)  # what the floor's own moment leaves
        t = np.einsum("kcim,...km->...kci", pinv, b)  # every candidate's minimum-norm solution on its set
        scale = np.linalg.norm(b, axis=-1)[..., None] / self.hole_radius + self.pretension  # [N]
        residual = np.linalg.norm(np.einsum("kmi,...kci->...kcm", A, t) - b[..., None, :], axis=-1)
        feasible = (t.min(axis=-1) >= -_RTOL * scale) & (residual <= _RTOL * self.hole_radius * scale)
        norm = np.where(feasible, np.sum(t * t, axis=-1), np.inf)
        best = np.take_along_axis(t, np.argmin(norm, axis=-1)[..., None, None], axis=-2)[..., 0, :]
        return self.pretension + np.maximum(best, 0.0)

    def _closed(self, torque: NDArray, sets: slice) -> NDArray[np.float64]:
        """(2): ``d = A^+ M``, then the common mode that puts the slackest tendon at ``P``."""
        # cos and sin of the selected rows at each call, as the rule always computed them: a vectorised
        # cosine over a longer array may round differently in its last bit.
        psi, n, r = self.psi[sets], self.psi.shape[1], self.hole_radius
        cos, sin = np.cos(psi), np.sin(psi)
        if self.axes == 1:  # A^+ = A^T / (A A^T), A = r cos(psi)
            d = torque[..., :1] * cos / (r * np.sum(cos * cos, axis=-1, keepdims=True))
        else:  # three unit vectors summing to zero are 120 deg apart: A A^T = (n / 2) r^2 I
            d = (2.0 / (n * r)) * (torque[..., :1] * cos + torque[..., 1:] * sin)
        return self.pretension + d - d.min(axis=-1, keepdims=True)


def tension_distribution(
    torque: NDArray, psi: NDArray, hole_radius: float, pretension: float, bending_axes: int = 2
) -> NDArray[np.float64]:
    """Joint-side tensions [N] that exert ``torque`` [N m] with every tendon at or above ``pretension``.

    The minimum-norm tension above the floor, (1) of :mod:`tendon_id.closed_loop.distribution`
    (:class:`TensionDistribution`, which a caller that distributes every period should build once).

    Parameters
    ----------
    torque : ndarray, shape (..., N, 2)
        Desired moments [N m]; a planar robot's (``bending_axes`` 1) ``M_y`` is not read.
    psi : ndarray, shape (N, n)
        Tendon azimuths [rad].
    hole_radius : float
        ``r`` [m].
    pretension : float
        ``P`` [N].
    bending_axes : int
        2 or 1 (a planar robot).

    Returns
    -------
    ndarray, shape (..., N, n)
    """
    return TensionDistribution(psi, hole_radius, pretension, bending_axes)(torque)
