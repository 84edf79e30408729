"""
What terminal-only data can tell you: tied against per-guide laws
=================================================================

A robot with a load cell only at its tip: which friction parameters, and which intermediate
tensions, do its data determine? This example runs the identifiability study of
:doc:`../guide/identifiability` on simulated ``terminal-only`` data, reads its numbers, and
checks its advice on which joint to instrument next.
"""

# %%
# Data with a known law
# ---------------------
#
# ``snake12-noise-only`` has a feasible friction law and no unmodelled effect, so the capstan
# model is right and the simulator's intermediate truth can score the ambiguity band. In
# ``terminal-only`` data the terminal joint scans while the proximal joints are held at a few
# poses.

import matplotlib.pyplot as plt
import numpy as np

from tendon_id.datasets import load_recipe
from tendon_id.identifiability import StudySettings, analyse
from tendon_id.report.identifiability import band_width_figure, posterior_figure
from tendon_id.sim import simulate

rec = simulate(load_recipe("snake12-noise-only"), "terminal-only", frames=6000, seed=3).recording
print(rec)

# %%
# The study
# ---------
#
# Small sampler settings keep the docs fast; the command line uses larger defaults.

result = analyse(rec, StudySettings(n_chains=32, n_steps=300, thin=10, band_frames=500))
js = result.to_dict()
print(f"model analysed: {js['model']}")
print(
    f"tied:      rank {js['tied']['rank']}/{js['tied']['n_params']}, "
    f"condition number {js['tied']['condition_number']:.3g}"
)
print(
    f"per-guide: rank {js['per_guide']['rank']}/{js['per_guide']['n_params']} "
    f"({js['per_guide']['n_unidentifiable']} unidentifiable directions)"
)
for words in js["per_guide"]["unidentifiable"][:1]:
    print("  ", words)

# %%
# A and B are sloppy, their sum is tight
# --------------------------------------
#
# At the few-degree wraps of a snake, :math:`\alpha\cos\alpha \approx \alpha`: the data see
# :math:`\mu(0) = A + B` and hardly anything else.

post = js["tied"]["posterior"]
for i in (1, 2, 3):
    a, m = post[f"A_t{i}"], post[f"mu0_t{i}"]
    print(
        f"tendon {i}: sd(A) = {a['sd']:.4f}, sd(A + B) = {m['sd']:.5f}, "
        f"corr(A, B) = {result.studies['tied'].correlation(i - 1)[0, 1]:.4f}"
    )
posterior_figure(result)
plt.show()

# %%
# The intermediate-tension ambiguity band
# ---------------------------------------
#
# Tied: narrow, and it covers the truth. Per-guide: the laws that fit the tip equally well
# disagree about where along the robot the friction is, so the band at the middle joints is
# several times wider.

b = js["bands"]
print(f"mean band: tied {b['tied_width_mean']:.2f} N, per-guide {b['per_guide_width_mean']:.2f} N")
print(
    f"truth inside the tied band: {100 * b['truth_coverage']:.1f} % of frames (worst joint "
    f"{100 * b['truth_coverage_min_joint']:.1f} %)"
)
band_width_figure(result)
plt.show()

# %%
# Which joint to instrument
# -------------------------
#
# The D-optimal joint, and the measured check: the band after adding each candidate joint's
# label (the simulator's truth plus load-cell noise).

adv = js["advice"]
widths = {c["joint"]: c["band_width_mean"] for c in adv["check"]}
print(f"instrument joint {adv['instrument_joint']}; excite joints {adv['excite_joints']}")
fig, ax = plt.subplots(figsize=(6, 3))
ax.bar(list(widths), list(widths.values()), color=["C3" if j == adv["instrument_joint"] else "C0" for j in widths])
ax.set_xlabel("joint instrumented")
ax.set_ylabel("mean per-guide band [N]")
ax.set_title("red: the D-optimal choice")
plt.show()
print(
    f"chosen {widths[adv['instrument_joint']]:.2f} N, median alternative "
    f"{np.median([w for j, w in widths.items() if j != adv['instrument_joint']]):.2f} N"
)
