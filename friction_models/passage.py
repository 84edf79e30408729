"""One capstan passage on a bench: a single tendon, or an antagonistic cable pair (:doc:`/guide/data`).

A tendon sliding over a curved surface loses tension along the direction it slides (the
Euler–Eytelwein capstan law, the paper's Eq. (1)): ``T_out = T_in exp(-sigma phi)`` with the
capstan exponent ``phi = mu alpha`` and ``sigma = +1`` when it slides from input to output
(forward slip), ``-1`` the other way.

An antagonistic pair drives a pulley of radius ``r_out`` from one of radius ``r_in`` through two
cables; input and output are torques. Cable 1 pulls the positive sense: in forward slip it runs
input -> output (``T1_out = T1_in e^{-phi}``) while cable 2 runs output -> input
(``T2_out = T2_in e^{+phi}``). With the tensions as moments at the input pulley
(``t = r_in T`` [N m]), the pretension moment ``P`` and torque balance ``t1 - t2 = u``:

* both cables taut: ``t1 = P + (u + g|u|)/2``, ``t2 = P + (g|u| - u)/2``, and
  ``tau_out = k (u cosh(phi) - (2P + g|u|) sinh(sigma phi))`` with ``k = r_out / r_in``: a gain
  and a direction-dependent offset, the band. The load sharing ``g`` in [0, 1] is how much of
  the load the slack side keeps: 0 when both cables stretch alike (the tension sum stays
  ``2P`` and the band does not grow with load), 1 when the slack side keeps its pretension (the
  band grows with ``|u|``, as for a single tendon);
* one cable slack (its tension would drop below 0): all the torque runs through the other,
  ``tau_out = k u exp(-sigma phi)`` (``u > 0``) or ``k u exp(+sigma phi)`` (``u < 0``).

The output is continuous and strictly increasing in ``u`` for either ``sigma``, so the inverse
(the input a given output needs) is exact: :func:`pair_input`.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["pair_tensions", "pair_output", "pair_input", "tendon_output", "tendon_input"]


def pair_tensions(
    u: ArrayLike, pretension: float, sharing: float = 0.0
) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """The two cables' tensions as moments at the input pulley [N m], for an input torque ``u`` [N m].

    ``t1 = max(P + (u + g|u|)/2, u, 0)`` and ``t2 = t1 - u``: both taut about the pretension
    ``P`` with load sharing ``g``, or one slack (0) and the other carrying the whole torque.
    """
    u = np.asarray(u, dtype=float)
    t1 = np.maximum(np.maximum(pretension + 0.5 * (u + sharing * np.abs(u)), u), 0.0)
    return t1, t1 - u


def pair_output(
    u: ArrayLike, pretension: float, phi: float, gain: float, sigma: ArrayLike, sharing: float = 0.0
) -> NDArray[np.float64]:
    """Output torque [N m] of an antagonistic pair slipping in direction ``sigma``.

    Parameters
    ----------
    u : array_like
        Input torque [N m].
    pretension : float
        Pretension moment ``P = r_in T_0`` [N m], >= 0.
    phi : float
        Capstan exponent ``mu alpha`` [-], >= 0.
    gain : float
        Radius ratio ``k = r_out / r_in`` [-].
    sigma : array_like
        +1 forward slip (input drives), -1 reverse; any value in [-1, 1] interpolates the exponent.
    sharing : float
        Load sharing ``g`` in [0, 1] [-].
    """
    t1, t2 = pair_tensions(u, pretension, sharing)
    s = np.asarray(sigma, dtype=float) * phi
    return gain * (t1 * np.exp(-s) - t2 * np.exp(s))


def pair_input(
    y: ArrayLike, pretension: float, phi: float, gain: float, sigma: ArrayLike, sharing: float = 0.0
) -> NDArray[np.float64]:
    """The input torque [N m] for which :func:`pair_output` gives ``y`` [N m] (its exact inverse)."""
    v = np.asarray(y, dtype=float) / gain
    s = np.asarray(sigma, dtype=float) * phi
    shifted = v + 2.0 * pretension * np.sinh(s)  # >= 0 exactly where u >= 0
    taut = np.where(
        shifted >= 0, shifted / (np.cosh(s) - sharing * np.sinh(s)), shifted / (np.cosh(s) + sharing * np.sinh(s))
    )
    if sharing >= 1.0:
        return taut
    u_slack = 2.0 * pretension / (1.0 - sharing)  # |u| beyond which one cable is slack
    return np.where(v >= u_slack * np.exp(-s), v * np.exp(s), np.where(v <= -u_slack * np.exp(s), v * np.exp(-s), taut))


def tendon_output(u: ArrayLike, phi: float, gain: float, sigma: ArrayLike) -> NDArray[np.float64]:
    """Output tension [N] of one tendon: ``k u exp(-sigma phi)`` (Eq. (1); ``k`` a sensor gain ratio)."""
    return gain * np.asarray(u, dtype=float) * np.exp(-np.asarray(sigma, dtype=float) * phi)


def tendon_input(y: ArrayLike, phi: float, gain: float, sigma: ArrayLike) -> NDArray[np.float64]:
    """The input tension [N] for which :func:`tendon_output` gives ``y`` [N]."""
    return np.asarray(y, dtype=float) * np.exp(np.asarray(sigma, dtype=float) * phi) / gain
