"""The simulated robot of the closed loop: joint dynamics driven through the truth transmission.

With ``JointDynamics(statics="full")``, the default, per joint ``k`` (two bending axes), a second-order joint
(:doc:`/guide/closed_loop`), driven by the ``n`` tendons of every set that crosses it (``n`` the robot's
``n_tendons``)::

    I_k theta_k'' + c_k theta_k' = tau_k
    tau_k = - sum_{j >= k} sum_i T[k, j, i] dl_kji/dtheta_k  + tau_g,k + tau_e,k

* every tendon that crosses joint ``k``, its own set's and the distal sets' passing through,
  pulls on it with the tension it has across the joint (the tendon Jacobian's transpose,
  :func:`~tendon_id.closed_loop.statics.tendon_moments`, exact in the pose);
* gravity and a payload, where the recipe's :class:`~tendon_id.sim.body.Body` switches them on
  (:func:`~tendon_id.closed_loop.statics.gravity_moments`);
* the joint's elastic return ``tau_e``: an isotropic backbone ``-K theta_k`` with ``K = g r``,
  the stiffness the simulator's actuation assumes towards a tendon (``elastic_return="backbone"``,
  the default); or the return that actuation implies in every direction
  (``"sectors"``, :func:`~tendon_id.closed_loop.statics.elastic_return`), ``g r`` towards a
  tendon and half that between two, but with no stiffness across the bend within 30 deg of a
  tendon, where one tendon alone pulls (why that is not the default: :doc:`/guide/closed_loop`);
* ``I_k`` the composite inertia of the chain distal to the joint
  (:func:`~tendon_id.closed_loop.statics.composite_inertia`) and ``c_k = 2 zeta sqrt(g r I_k)``.

A planar robot (``bending_axes`` 1) has hinges: each joint turns about its y axis alone, so
``theta_y`` and its rate are held at zero and the hinge's bearing reacts every moment about the
joint's other axis (the tendons', gravity's); the x axis moves as above.

The low-level puller-follower controller realises a commanded actuator tension with a first
order lag ``tau_a`` (the paper gives no figure; 50 ms is a typical tension loop).  Between
controller updates the plant integrates at ``dt``: the elastic return is linear within each
sector of bend directions where the same tendons pull, so each joint's
linear part is discretised exactly for its current sector (zero-order hold, matrix exponential,
precomputed for every sector), and the tendons' and gravity's moments are held over the step.
The transmission is stepped at every ``dt`` with its stick/slip and viscoelastic state carried
(:class:`~tendon_id.sim.stepper.TransmissionStepper`), and gives the whole chain ``T[k, j, i]``.

``statics="own_set"`` is the earlier plant, kept for comparison: joint ``k`` driven by its own
set at first order, ``r sum_i T[k, k, i] u_ki``, against an isotropic stiffness ``g r``, with
1e-3 kg m^2 at every joint (:class:`JointDynamics`).

Why 1 ms is small enough: each joint's linear part is discretised exactly, and the held moments
change within a step only as fast as the 50 ms actuator lag and the joints move.  Measured on
both plants (``tests/closed_loop``): halving the step moves the closed-loop angles by less
than an encoder count on average and the RMS error by under 5 %.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.linalg import expm

from tendon_id.closed_loop.statics import (
    composite_inertia,
    crossing_jacobian,
    elastic_return,
    gravity_moments,
    tendon_moments,
)
from tendon_id.errors import ConfigError
from tendon_id.geometry import RobotGeometry, own_bend, tendon_azimuths
from tendon_id.sim import Recipe
from tendon_id.sim.stepper import TransmissionStepper

__all__ = ["JointDynamics", "Plant", "joint_torque"]


@dataclass(frozen=True)
class JointDynamics:
    """Mechanical parameters of every joint, per bending axis.

    Parameters
    ----------
    statics : {"own_set", "full"}
        ``"full"``: every tendon crossing a joint pulls on it through the exact tendon Jacobian,
        gravity and the payload act where the body switches them on, each joint carries its
        composite inertia, and the elastic return is ``elastic_return`` (the module's equations);
        the default.  ``"own_set"`` (the earlier plant): joint ``k`` is driven by its own set at
        first order, ``r sum_i T[k, k, i] u_ki``, with an isotropic stiffness ``g r`` and 1e-3
        kg m^2 at every joint.
    inertia : float, optional
        ``I`` [kg m^2] of every joint. Default (None): each joint's composite inertia, from the
        recipe's :class:`~tendon_id.sim.body.Body` (1.1e-1 at the base to 6.6e-5 at the tip for
        ``snake12-paper``'s robot) under ``"full"``; 1e-3 under ``"own_set"``.
    stiffness : float, optional
        An isotropic joint stiffness ``K`` [N m/rad] in place of the elastic return the actuation
        assumes (:func:`~tendon_id.closed_loop.statics.elastic_return`), for tests and what-ifs.
        Default (None): ``g r``, the actuation's gain times the hole radius (in every direction,
        except under ``elastic_return="sectors"``).
    elastic_return : {"backbone", "sectors"}
        Under ``"full"``: ``"backbone"`` (default), an isotropic ``K``, the joint's elastic
        backbone, with ``K = g r`` unless ``stiffness`` is given; ``"sectors"``, the return the
        open-loop actuation implies (:func:`~tendon_id.closed_loop.statics.elastic_return`), whose
        stiffness is singular within 30 deg of each tendon (:doc:`/guide/closed_loop`).
    damping_ratio : float
        ``zeta`` [-]; ``c = 2 zeta sqrt(K I)`` with ``K`` the stiffness towards a tendon. Default 1
        (a joint with hysteretic friction in its bearings shows no ringing).
    actuator_tau : float
        Time constant of the low-level tension loop [s]. Default 0.05.
    """

    statics: str = "full"
    inertia: float | None = None
    stiffness: float | None = None
    elastic_return: str = "backbone"
    damping_ratio: float = 1.0
    actuator_tau: float = 0.05

    def __post_init__(self) -> None:
        if self.statics not in ("own_set", "full"):
            raise ConfigError(f"joint dynamics' statics must be 'own_set' or 'full', got {self.statics!r}")
        if self.elastic_return not in ("backbone", "sectors"):
            raise ConfigError(
                f"joint dynamics' elastic_return must be 'backbone' or 'sectors', got {self.elastic_return!r}"
            )
        if (self.inertia is not None and self.inertia <= 0) or self.damping_ratio < 0 or self.actuator_tau <= 0:
            raise ConfigError("joint dynamics need inertia > 0, damping_ratio >= 0 and actuator_tau > 0")
        if self.stiffness is not None and self.stiffness < 0:
            raise ConfigError(f"joint stiffness must be >= 0 N m/rad, got {self.stiffness}")

    def stiffness_for(self, recipe: Recipe, geometry: RobotGeometry) -> float:
        """``K`` [N m/rad] towards a tendon: the override, or the actuation gain times the hole radius."""
        if self.stiffness is not None:
            return float(self.stiffness)
        return recipe.actuation.gain_n_per_rad * geometry.hole_radius

    def inertia_for(self, recipe: Recipe, geometry: RobotGeometry) -> NDArray[np.float64]:
        """``I_k`` [kg m^2] per joint, shape (N,)."""
        if self.inertia is not None or self.statics == "own_set":
            return np.full(geometry.n_modules, 1e-3 if self.inertia is None else float(self.inertia))
        return composite_inertia(geometry, recipe.body)


def joint_torque(joint_side: NDArray, psi: NDArray, hole_radius: float) -> NDArray:
    """First-order moment of each set's own joint-side tensions about its joint [N m], shape (..., N, 2).

    ``r sum_i T[k, k, i] (cos psi_ki, sin psi_ki)``: the straight robot's tendon Jacobian, own set
    only; what a joint's own tendons contribute at small bends.  The plant's full moment, every
    tendon crossing the joint, is :func:`~tendon_id.closed_loop.statics.tendon_moments`.
    """
    return hole_radius * np.stack(
        [np.sum(joint_side * np.cos(psi), axis=-1), np.sum(joint_side * np.sin(psi), axis=-1)], axis=-1
    )


def _sector_matrices(inertia: NDArray, stiffness: NDArray, damping: NDArray, dt: float) -> tuple[NDArray, NDArray]:
    """Exact zero-order-hold matrices of ``I x'' + c x' + K x = tau`` for each joint and 2x2 ``K``.

    ``stiffness`` (N, P, 2, 2); returns ``Phi`` (N, P, 4, 4) and ``Gamma`` (N, P, 4, 2) for the state
    ``(theta, omega)``: ``expm([[A, B], [0, 0]] dt)`` with ``A = [[0, 1], [-K/I, -c/I]]``.
    """
    n, p = stiffness.shape[:2]
    phi, gamma = np.empty((n, p, 4, 4)), np.empty((n, p, 4, 2))
    eye = np.eye(2)
    for k in range(n):
        for q in range(p):
            m = np.zeros((6, 6))
            m[:2, 2:4] = eye
            m[2:4, :2] = -stiffness[k, q] / inertia[k]
            m[2:4, 2:4] = -damping[k] / inertia[k] * eye
            m[2:4, 4:6] = eye / inertia[k]
            e = expm(m * dt)
            phi[k, q], gamma[k, q] = e[:4, :4], e[:4, 4:6]
    return phi, gamma


class Plant:
    """A batch of simulated robots, advanced by one controller period at a time.

    Parameters
    ----------
    recipe : Recipe
        Robot, friction law, effects and body of the truth (its ``snake`` robot is used).
    batch : int
        Number of independent robots (one per estimator, for example).
    dynamics : JointDynamics
    dt : float
        Integration step [s]. Default 1 ms (1 kHz).

    Attributes
    ----------
    theta, omega : ndarray, shape (B, N, 2)
        Joint angles [rad] and rates [rad/s]; ``theta_y`` and its rate stay zero on a planar robot
        (``bending_axes`` 1).
    actuator : ndarray, shape (B, N, n)
        True actuator-side tensions [N], ``n`` tendons per set.
    chain : ndarray, shape (B, N, N, n)
        ``T[k, j, i]`` [N], every tendon across every joint it crosses (zero where ``k > j``).
    joint_side : ndarray, shape (B, N, n)
        ``T[j, j, i]`` [N], the diagonal of ``chain``.
    """

    def __init__(self, recipe: Recipe, batch: int, dynamics: JointDynamics | None = None, dt: float = 1e-3):
        self.recipe = recipe
        self.geometry = recipe.robot_for("posterior-3")
        self.dynamics = dynamics or JointDynamics()
        self.dt = float(dt)
        self.batch = int(batch)
        self.psi = tendon_azimuths(self.geometry)
        self.n_tendons = self.geometry.n_tendons
        self.planar = self.geometry.bending_axes == 1
        self.stiffness = self.dynamics.stiffness_for(recipe, self.geometry)
        self.inertia = self.dynamics.inertia_for(recipe, self.geometry)
        self.gain = recipe.actuation.gain_n_per_rad
        self.full = self.dynamics.statics == "full"
        sectors = self.full and self.dynamics.elastic_return == "sectors"
        self.isotropic = self.dynamics.stiffness is not None or not sectors
        damping = 2.0 * self.dynamics.damping_ratio * np.sqrt(self.stiffness * self.inertia)
        # The elastic return's stiffness in each sector: the tendons with b > 0 (bit i of the sector's index).
        nt = self.n_tendons
        u = np.stack([np.cos(self.psi), np.sin(self.psi)], axis=-1)  # (N, n, 2)
        pulls = (np.arange(2**nt)[:, None] >> np.arange(nt)[None, :]) & 1  # (2^n sectors, n tendons)
        if self.isotropic:
            k_sector = np.broadcast_to(self.stiffness * np.eye(2), (self.geometry.n_modules, 1, 2, 2))
        else:
            r = self.geometry.hole_radius
            k_sector = r * self.gain * np.einsum("qi,kia,kib->kqab", pulls, u, u)
        self.phi, self.gamma = _sector_matrices(self.inertia, k_sector, damping, self.dt)
        self._bits = 1 << np.arange(nt)
        self.a_act = np.exp(-self.dt / self.dynamics.actuator_tau)
        self.stepper = TransmissionStepper(self.geometry, recipe.friction, recipe.effects, self.dt, self.batch)
        self.reset()

    def sector(self, theta: NDArray) -> NDArray[np.intp]:
        """Index of each joint's elastic-return sector (which tendons pull), shape (B, N)."""
        if self.isotropic:
            return np.zeros(theta.shape[:-1], dtype=np.intp)
        return ((own_bend(theta, self.psi) > 0) * self._bits).sum(axis=-1)

    def crossing_jacobian(self, theta: NDArray) -> NDArray[np.float64]:
        """``dl_kji/dtheta_k`` [m/rad], shape (B, N, N, n, 2): exact under ``"full"``; own set at first order else."""
        if self.full:
            return crossing_jacobian(theta, self.geometry)
        n = self.geometry.n_modules
        jac = np.zeros(np.shape(theta)[:-2] + (n, n, self.n_tendons, 2))
        own = -self.geometry.hole_radius * np.stack([np.cos(self.psi), np.sin(self.psi)], axis=-1)
        jac[..., np.arange(n), np.arange(n), :, :] = own
        return jac

    def static_moments(self, theta: NDArray, chain: NDArray) -> NDArray[np.float64]:
        """The tendons' and gravity's moments about each joint [N m], shape (B, N, 2) (the elastic return apart)."""
        if not self.full:  # each set's own joint side at first order: the earlier plant, to the bit
            n = self.geometry.n_modules
            return joint_torque(chain[..., np.arange(n), np.arange(n), :], self.psi, self.geometry.hole_radius)
        return tendon_moments(chain, crossing_jacobian(theta, self.geometry)) + self.gravity_moments(theta)

    def gravity_moments(self, theta: NDArray) -> NDArray[np.float64]:
        """Gravity's and the payload's moments about each joint [N m], shape (B, N, 2); zero unless both apply."""
        if not (self.full and self.recipe.body.gravity):
            return np.zeros(np.shape(theta))
        return gravity_moments(theta, self.geometry, self.recipe.body)

    def elastic_moments(self, theta: NDArray) -> NDArray[np.float64]:
        """The joints' elastic return [N m], shape (B, N, 2)."""
        if self.isotropic:
            return -self.stiffness * np.asarray(theta, dtype=float)
        return elastic_return(theta, self.psi, self.gain, self.geometry.hole_radius)

    def reset(self, actuator: NDArray | None = None) -> None:
        """Straight robots at rest; actuator tensions ``actuator`` (B, N, n) [N] (default: 1 N)."""
        n = self.geometry.n_modules
        self.theta = np.zeros((self.batch, n, 2))
        self.omega = np.zeros((self.batch, n, 2))
        shape = (self.batch, n, self.n_tendons)
        self.actuator = np.ones(shape) if actuator is None else np.array(actuator, dtype=float)
        if self.actuator.shape != shape:
            raise ConfigError(f"the plant's actuator tensions need shape {shape}, got {self.actuator.shape}")
        self.stepper.reset()
        self.joint_side, self.sigma = self.stepper.step(self.theta, self.actuator)

    @property
    def chain(self) -> NDArray[np.float64]:
        """``T[k, j, i]`` [N] of every robot, shape (B, N, N, n), zero where ``k > j``."""
        return self.stepper.chain

    def advance(self, command: NDArray, duration: float) -> None:
        """Hold the commanded actuator tensions ``command`` (B, N, n) [N] for ``duration`` [s]."""
        steps = int(round(duration / self.dt))
        if steps < 1 or abs(steps * self.dt - duration) > 1e-9:
            raise ConfigError(f"the controller period {duration} s must be a multiple of the plant step {self.dt} s")
        command = np.asarray(command, dtype=float)
        joints = np.arange(self.geometry.n_modules)
        for _ in range(steps):
            if self.full:
                tau = self.static_moments(self.theta, self.chain)
            else:  # from the joint sides the stepper returns: no chain need be formed
                tau = joint_torque(self.joint_side, self.psi, self.geometry.hole_radius)
            if self.planar:  # the hinge's bearing reacts the moment about the other axis
                tau[..., 1] = 0.0
            q = self.sector(self.theta)
            phi, gamma = self.phi[joints, q], self.gamma[joints, q]  # (B, N, 4, 4), (B, N, 4, 2)
            x = np.concatenate([self.theta, self.omega], axis=-1)
            x = np.einsum("bkij,bkj->bki", phi, x) + np.einsum("bkij,bkj->bki", gamma, tau)
            if self.planar:  # theta_y and its rate: a sector's stiffness may couple the axes, the hinge does not
                x[..., 1::2] = 0.0
            self.theta, self.omega = x[..., :2], x[..., 2:]
            self.actuator = self.a_act * self.actuator + (1.0 - self.a_act) * command
            self.joint_side, self.sigma = self.stepper.step(self.theta, self.actuator)
