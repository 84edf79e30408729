"""
Simulate a recording and look inside it
=======================================

The simulator of :mod:`tendon_id.sim` is the ground truth tendon-id measures every method
against. Here we simulate the paper's ``posterior-3`` protocol (step-and-hold on modules 10--12)
of the ``snake12-paper`` recipe, then look at what a robot would log and at the hidden state behind
it: the tension along the chain, the wrap of every guide, and the stick/slip state of the
nonsmooth capstan.
"""

# %%
# Simulate
# --------
#
# :func:`tendon_id.sim.simulate` returns a :class:`~tendon_id.sim.SimulationResult`: the
# :class:`~tendon_id.data.Recording` a robot would log (plus the intermediate joint-side truth
# that only a simulator has) and the hidden state behind it. ``frames=1500`` keeps this example
# fast; the paper's protocol has 5000 frames.

import matplotlib.pyplot as plt
import numpy as np

import tendon_id.datasets
import tendon_id.sim

recipe = tendon_id.datasets.load_recipe("snake12-paper")
result = tendon_id.sim.simulate(recipe, "posterior-3", frames=1500, seed=1)
rec = result.recording
print(rec)
print(rec.summary("posterior-3 (simulated)"))

# %%
# The recipe switches on these unmodelled effects, with the paper's friction law as the truth:

print("effects:", ", ".join(rec.meta["effects"]))
print("friction truth:", rec.meta["friction_truth"])

# %%
# Actuator side, terminal label and intermediate truth
# ----------------------------------------------------
#
# Take one trajectory. For the terminal set (:math:`j = N = 12`) the actuator-side tension
# :math:`T[1, N, i]` is measured, the tension drops guide by guide along the chain
# (``result.chain[:, k-1, j-1, i-1]`` is :math:`T[k, j, i]`), and the terminal load cell reads
# :math:`T[N, N, i]`, the only joint-side label a real robot gives. For an intermediate joint,
# here joint 10, only the simulator knows the joint side.

n = rec.n_modules
traj = rec.trajectories[1]
rows = np.flatnonzero(rec.trajectory_ids == traj)
t = rec.time[rows]
tendon = 0  # tendon i = 1

fig, axes = plt.subplots(2, 1, figsize=(10, 6.5), sharex=True, layout="constrained")
ax = axes[0]
ax.plot(t, rec.actuator[rows, n - 1, tendon], color="k", lw=2, label=r"actuator side $T[1, 12, 1]$ (measured)")
for k in (4, 8, 11):
    ax.plot(t, result.chain[rows, k - 1, n - 1, tendon], lw=1, label=f"after guide {k - 1}: $T[{k}, 12, 1]$ (hidden)")
ax.plot(t, rec.terminal[rows, tendon], color="C3", lw=1.5, label=r"terminal label $T[12, 12, 1]$ (measured)")
ax.set_ylabel("tension [N]")
ax.set_title(f"set 12, tendon 1, trajectory {traj}")
ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0))

ax = axes[1]
j = 10
for i in range(3):
    ax.plot(t, rec.actuator[rows, j - 1, i], color=f"C{i}", lw=1, ls="--")
    ax.plot(t, rec.joint_truth[rows, j - 1, i], color=f"C{i}", lw=1.5, label=f"tendon {i + 1}")
ax.set_ylabel("tension [N]")
ax.set_xlabel("time [s]")
ax.set_title(f"joint {j}: actuator side (dashed) vs joint-side truth (solid)")
ax.legend(fontsize=8, loc="upper left", bbox_to_anchor=(1.01, 1.0))
plt.show()

# %%
# The joint-side tensions of the intermediate joints are exactly what terminal-only labels do not
# pin down. :meth:`~tendon_id.data.Recording.fitting_view` hides them from any model's ``fit``:

print("truth columns before:", rec.has_truth, "- in the fitting view:", rec.fitting_view().has_truth)

# %%
# Wrap per guide
# --------------
#
# The backbone wrap :math:`\alpha_k` of each guide (``result.wrap``, the paper's
# :math:`\mathrm{Geom}(q_k)`) follows the steps of modules 10--12, on top of the routing wrap
# :math:`\alpha_0` and the held proximal pose. Below the clearance angle :math:`\alpha_c` the
# ``contact`` gate is closed and the guide loses nothing.
#
# The recipe's ``per_tendon_wrap`` effect makes the truth use each tendon's exact wrap from the
# forward kinematics of the hole points instead (:func:`tendon_id.geometry.exact_wrap`). The
# models only see the backbone wrap. The difference comes from the Cardan twist, so it appears
# only where both axes of a joint are bent (here at the held proximal joints, not at the
# single-axis steps of joints 10--12), and at bends of a few degrees it is a fraction of a degree.

from tendon_id.geometry import RobotGeometry, exact_wrap

geometry = RobotGeometry.from_dict(rec.meta["robot"])
exact = exact_wrap(result.theta_true[rows], geometry)  # (T, N-1, N, 3)

fig, axes = plt.subplots(1, 2, figsize=(12, 4.2), layout="constrained")
ax = axes[0]
colors = plt.cm.viridis(np.linspace(0, 1, n - 1))
for k in range(1, n):
    ax.plot(t, np.degrees(result.wrap[rows, k - 1]), color=colors[k - 1], label=f"guide {k}")
ax.axhline(np.degrees(geometry.alpha_c), color="gray", ls=":", lw=1)
ax.text(
    t[-1], np.degrees(geometry.alpha_c), r"clearance $\alpha_c$ ", ha="right", va="bottom", fontsize=8, color="gray"
)
ax.set_xlabel("time [s]")
ax.set_ylabel("backbone wrap [deg]")
ax.set_title("backbone wrap per guide")
ax.legend(fontsize=7, ncol=2, loc="upper left", bbox_to_anchor=(1.01, 1.0))

ax = axes[1]
for k in (2, 5, 10):
    for i in range(3):
        diff = np.degrees(exact[:, k - 1, n - 1, i] - result.wrap[rows, k - 1])
        ax.plot(t, diff, color=f"C{i}", ls={2: "-", 5: "--", 10: ":"}[k], lw=1.2, label=f"guide {k}, tendon {i + 1}")
ax.set_xlabel("time [s]")
ax.set_ylabel("exact minus backbone wrap [deg]")
ax.set_title("per-tendon wrap of set 12")
ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0))
plt.show()

# %%
# Stick and slip
# --------------
#
# With ``stick_slip`` on, each guide is a play operator in the log domain: the output tension
# stays where it was (stick, :math:`\sigma = 0`) until it reaches an edge of the capstan cone
# :math:`T_{in} e^{\mp\phi}`, where it slides forward (:math:`\sigma = +1`) or back
# (:math:`\sigma = -1`). ``result.sigma`` has shape (T, N-1, N, 3): guide, set, tendon.
#
# Here is the terminal set at guide 2 on the first trajectory. This close to the actuator the
# input of the guide is nearly the actuator-side tension: it steps when the controller pulls on
# joint 12 (its antagonistic share) and drifts slowly with the pretension. While the input rises
# the tendon slides forward and loses tension; when it falls the tendon sticks, then slides back,
# and the output is then *higher* than the input.

traj = rec.trajectories[0]
rows = np.flatnonzero(rec.trajectory_ids == traj)
t = rec.time[rows]
g = 2
print("sigma shape:", result.sigma.shape)
sig = result.sigma[rows, g - 1, n - 1, :]  # (T, 3)
t_in = result.chain[rows, g - 1, n - 1, :]  # T[g, 12, :], entering guide g
t_out = result.chain[rows, g, n - 1, :]  # T[g+1, 12, :], leaving it
for i in range(3):
    share = {s: float(np.mean(sig[:, i] == s)) for s in (-1, 0, 1)}
    print(f"tendon {i + 1}: reverse slip {share[-1]:.0%}, stick {share[0]:.0%}, forward slip {share[1]:.0%}")

fig, axes = plt.subplots(3, 1, figsize=(8, 7.5), sharex=True, layout="constrained")
for i in range(3):
    axes[0].plot(t, t_in[:, i], color=f"C{i}", lw=1, ls="--")
    axes[0].plot(t, t_out[:, i], color=f"C{i}", lw=1.5, label=f"tendon {i + 1}")
    axes[1].plot(t, np.log(t_out[:, i] / t_in[:, i]), color=f"C{i}", lw=1)
    axes[2].step(t, sig[:, i] + 0.06 * (i - 1), where="post", color=f"C{i}", lw=1)
axes[0].set_ylabel("tension [N]")
axes[0].set_title(f"set 12 at guide {g}, trajectory {traj}: input (dashed) and output (solid)", fontsize=10)
axes[0].legend(fontsize=8)
axes[1].axhline(0.0, color="k", lw=0.6)
axes[1].set_ylabel(r"$\ln(T_{out}/T_{in})$")
axes[2].set_yticks([-1, 0, 1], ["reverse slip", "stick", "forward slip"])
axes[2].set_xlabel("time [s]")
axes[2].set_title("slip state sigma (offset slightly per tendon)", fontsize=10)
plt.show()

# %%
# Every reversal of the input sends a tendon through a stick phase before it slips the other way:
# the hysteresis that a static capstan model cannot represent, and that the ``capstan-nonsmooth``
# baseline and PG-CHTC's temporal residual are there to capture.
