"""
Friction laws, the capstan ratio and stick/slip hysteresis
==========================================================

The physics vocabulary of tendon-id lives in :mod:`friction_models`: vectorised numpy functions
that know nothing about recordings. This example plots the paper's per-tendon friction law, the
capstan tension ratio it implies through one guide, and the hysteresis loop of the nonsmooth
capstan (the play operator) under a sinusoidal input tension.
"""

# %%
# The affine-cosine friction law
# ------------------------------
#
# The paper (Eq. (4)) models the friction coefficient of tendon :math:`i` as affine in the cosine
# of the wrap, :math:`\mu_i(\alpha) = A_i \cos\alpha + B_i`, and identifies
# :math:`(A_i, B_i) = (0.30, 0.09), (0.32, 0.08), (0.28, 0.10)`.

import matplotlib.pyplot as plt
import numpy as np

import friction_models as fm

A = np.array([0.30, 0.32, 0.28])
B = np.array([0.09, 0.08, 0.10])
alpha = np.linspace(0.0, np.pi, 721)[:, None]  # (721, 1) broadcasts against the 3 tendons
mu = fm.affine_cosine_mu(alpha, A, B)  # (721, 3)

fig, ax = plt.subplots(figsize=(7, 4), layout="constrained")
deg = np.degrees(alpha[:, 0])
for i in range(3):
    ax.plot(deg, mu[:, i], label=f"tendon {i + 1}: A={A[i]:.2f}, B={B[i]:.2f}")
ax.axhline(0.0, color="k", lw=0.8)
ax.axvspan(0, 30, color="C2", alpha=0.1, label="wraps a snake's guides reach")
ax.set_xlabel(r"wrap $\alpha$ [deg]")
ax.set_ylabel(r"$\mu_i(\alpha)$")
ax.set_xlim(0, 180)
ax.legend(fontsize=8)
ax.set_title(r"$\mu_i(\alpha) = A_i\cos\alpha + B_i$")
plt.show()

# %%
# The paper's values have :math:`B_i < |A_i|`, so :math:`\mu_i` turns negative beyond
# :math:`\arccos(-B_i/A_i)`, about 105 degrees of wrap. Calibration in tendon-id imposes
# :math:`\mu_i \ge 0` on :math:`[0, \pi]`, i.e. :math:`B_i \ge |A_i|`; the simulator keeps the
# paper's values and only requires :math:`\mu \ge 0` on the wraps it visits.

for i in range(3):
    print(
        f"tendon {i + 1}: mu(0) = A + B = {A[i] + B[i]:.2f}, "
        f"negative beyond {np.degrees(np.arccos(-B[i] / A[i])):.1f} deg, B >= |A|: {B[i] >= abs(A[i])}"
    )

# %%
# The capstan ratio through one guide
# -----------------------------------
#
# Through a guide with wrap :math:`\alpha` a sliding tendon keeps the fraction
# :math:`r = e^{-\beta\,\mu(\alpha)\,\alpha}` of its tension (:func:`friction_models.capstan_exponent`,
# :func:`friction_models.capstan_ratio`). With the contact gate :math:`\beta`, a tendon that
# turns by less than the clearance angle of the hole loses nothing there. The classic
# Euler--Eytelwein law uses a constant coefficient; with :math:`\mu = \mu(0) = A + B` it
# overestimates the loss at large wraps.

from tendon_id.geometry import RobotGeometry

alpha_c = RobotGeometry().alpha_c  # rad, the default clearance angle of a hole
a = np.linspace(0.0, np.radians(60.0), 601)[:, None]
phi = fm.capstan_exponent(fm.affine_cosine_mu(a, A, B), a)
phi_gated = fm.capstan_exponent(fm.affine_cosine_mu(a, A, B), a, fm.hard_contact_gate(a, alpha_c))
phi_const = fm.capstan_exponent(fm.constant_mu(a, A + B), a)

fig, ax = plt.subplots(figsize=(7, 4), layout="constrained")
da = np.degrees(a[:, 0])
for i in range(3):
    ax.plot(da, fm.capstan_ratio(phi[:, i]), color=f"C{i}", label=f"tendon {i + 1}")
    ax.plot(da, fm.capstan_ratio(phi_const[:, i]), color=f"C{i}", ls=":", lw=1)
ax.plot(da, fm.capstan_ratio(phi_gated[:, 0]), color="k", lw=1, ls="--", label=r"tendon 1 with contact gate")
ax.set_xlabel(r"wrap $\alpha$ [deg]")
ax.set_ylabel(r"$T_{out}/T_{in}$ (forward slip)")
ax.set_title("capstan ratio; dotted: constant $\\mu = A + B$")
ax.legend(fontsize=8)
plt.show()

# %%
# Over a chain the ratios multiply: the terminal set of a 12-module robot passes 11 guides, so
# even a few degrees of wrap per guide add up to a large loss.

wrap = np.radians(8.0)
r_one = fm.capstan_ratio(fm.capstan_exponent(fm.affine_cosine_mu(wrap, A, B), wrap))
print("ratio through one guide at 8 deg:", np.round(r_one, 3))
print("ratio through 11 guides at 8 deg:", np.round(r_one**11, 3))

# %%
# Stick/slip: the play operator
# -----------------------------
#
# With Coulomb friction the output tension of a passage may lie anywhere in the capstan cone
# :math:`T_{in} e^{-\phi} \le T_{out} \le T_{in} e^{+\phi}`. Inside it the tendon sticks and the
# output keeps its previous value; on the lower edge it slides forward, on the upper edge back. In
# the log domain this is the play operator (:func:`friction_models.play_operator`)
#
# .. math::
#
#    \ln T_{out}(t) = \operatorname{clamp}\big(\ln T_{out}(t-1),\ \ln T_{in}(t) - \phi,\ \ln T_{in}(t) + \phi\big).
#
# Drive it with a sinusoidal input tension through a guide wrapped by 25 degrees.

t = np.arange(0.0, 60.0, 0.1)  # 10 Hz, two periods
t_in = 150.0 + 60.0 * np.sin(2 * np.pi * t / 30.0)
wrap = np.radians(25.0)
phi = float(fm.capstan_exponent(fm.affine_cosine_mu(wrap, A[0], B[0]), wrap))
res = fm.play_operator(np.log(t_in), phi)
t_out = np.exp(res.log_out)
print(f"phi = {phi:.3f}; the cone is T_in x [{np.exp(-phi):.3f}, {np.exp(phi):.3f}]")

fig, axes = plt.subplots(1, 2, figsize=(10, 4.6), layout="constrained")
ax = axes[0]
lo, hi = t_in * np.exp(-phi), t_in * np.exp(phi)
order = np.argsort(t_in)
ax.plot(t_in[order], lo[order], color="gray", lw=0.8, ls="--")
ax.plot(t_in[order], hi[order], color="gray", lw=0.8, ls="--", label="cone edges")
names = {1: "forward slip", 0: "stick", -1: "reverse slip"}
for s, color in ((1, "C0"), (0, "C2"), (-1, "C3")):
    m = res.sigma == s
    ax.scatter(t_in[m], t_out[m], s=6, color=color, label=names[s], zorder=3)
ax.plot(t_in, t_out, color="k", lw=0.5, zorder=2)
ax.set_xlabel(r"$T_{in}$ [N]")
ax.set_ylabel(r"$T_{out}$ [N]")
ax.set_title("hysteresis loop")
ax.legend(fontsize=8)

ax = axes[1]
ax.plot(t, t_in, color="k", label=r"$T_{in}$")
ax.plot(t, t_out, color="C0", label=r"$T_{out}$ (play operator)")
ax.plot(t, t_in * np.exp(-phi), color="C0", ls=":", label=r"$T_{in}e^{-\phi}$ (always slipping)")
ax.set_xlabel("time [s]")
ax.set_ylabel("tension [N]")
ax.set_title("in time: the output sticks after each reversal")
ax.legend(fontsize=8, loc="upper center", bbox_to_anchor=(0.5, -0.15), ncol=3)
plt.show()

# %%
# Going up, the tendon slides forward and loses :math:`e^{-\phi}`; at the top the input reverses,
# the tendon sticks until the input has dropped by a factor :math:`e^{-2\phi}`, then slides back
# and the output *exceeds* the input. A static capstan model sees only the lower edge, which is
# why its residual jumps at every reversal.
