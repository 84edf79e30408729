"""
Calibrating the capstan law, and how far to trust it
====================================================

This example calibrates the per-tendon friction law :math:`\\mu_i(\\alpha) = A_i\\cos\\alpha + B_i`
of a 12-module snake from **terminal-only** labels, samples its Bayesian posterior with emcee,
and turns the posterior into uncertainty bands on the joint-side tensions of joints that have no
sensor. It then fits two capstan models to data with physics they do not know, to show what
misspecification looks like.

See :doc:`../guide/calibration` for the method and :doc:`../guide/zoo` for the estimator
interface.
"""

# %%
# Data with a known law
# ---------------------
#
# The recipe ``snake12-noise-only`` is the robot of ``snake12-paper`` with a *feasible* friction
# law (:math:`B_i \ge |A_i|`) and no unmodelled effect: the only imperfections are 1 N load-cell
# noise and 12-bit encoder quantisation. The capstan-simple model is then exactly right, so the
# calibrated law can be compared with the truth the simulator stored in the metadata.
#
# Splits are made by trajectory, never by frame.

import time

import arviz as az
import matplotlib.pyplot as plt
import numpy as np
import pandas as pd

import tendon_id.calibration.posterior
import tendon_id.datasets
import tendon_id.sim
from tendon_id import zoo

pd.set_option("display.width", 120)
pd.set_option("display.max_columns", 12)
t_start = time.perf_counter()
rec = tendon_id.sim.simulate(
    tendon_id.datasets.load_recipe("snake12-noise-only"), "terminal-only", frames=6000, seed=0
).recording
train, test = rec.split((0.7, 0.3), seed=0)
print(
    f"{rec.n_frames} frames, {len(rec.trajectories)} trajectories: "
    f"train {train.n_frames} frames ({len(train.trajectories)} traj.), "
    f"test {test.n_frames} frames ({len(test.trajectories)} traj.)"
)

# %%
# Constrained calibration
# -----------------------
#
# :meth:`~tendon_id.zoo.CapstanModel.fit` only ever sees ``train.fitting_view()``: the
# intermediate joint-side truth columns are removed before anything is read. ``capstan-simple``
# is smooth (:math:`\ln T_N` is linear in :math:`(A_i, B_i)`), so nlopt's SLSQP solves the
# constrained least-squares problem in the log domain with its exact gradient, in milliseconds.

model = zoo.make("capstan-simple").fit(train)
truth = rec.meta["friction_truth"]
A_true, B_true = np.array(truth["A"]), np.array(truth["B"])

fit_table = pd.DataFrame(
    {
        "A fitted": model.A_[0],
        "A true": A_true,
        "B fitted": model.B_[0],
        "B true": B_true,
        "mu0 fitted": model.mu0_[0],
        "mu0 true": A_true + B_true,
    },
    index=[f"tendon {i}" for i in (1, 2, 3)],
)
print(fit_table.round(4))
print(
    f"calibration: {model.calibration_['n_eval']} evaluations, "
    f"{model.calibration_['seconds'] * 1e3:.1f} ms, status {model.calibration_['status']}"
)

# %%
# :math:`\mu_i(0) = A_i + B_i` is recovered to a fraction of a percent; the split between
# :math:`A_i` and :math:`B_i` is much less certain. Snake guides wrap by a few degrees only, where
# :math:`\cos\alpha \approx 1`, so the terminal data pin down the sum far better than the parts.
# The posterior makes this visible.
#
# The emcee posterior
# -------------------
#
# :func:`tendon_id.calibration.posterior.sample_posterior` samples :math:`(A_i, B_i, \ln\sigma_i)` under the
# same constraint :math:`B_i \ge |A_i|`. For a smooth model the log-probability costs
# :math:`O(1)` per walker whatever the number of frames, and it is vectorised over walkers.
# Sampling stops when the chain is longer than 50 autocorrelation times and every parameter
# reaches the target effective sample size. The encoder-quantisation error is marginalised.

post = tendon_id.calibration.posterior.sample_posterior(model, train, target_ess=400, seed=0)
print(
    f"{post.chain.shape[0]} steps x {post.chain.shape[1]} walkers kept, "
    f"max tau {post.tau.max():.0f} steps, acceptance {post.acceptance:.2f}, {post.seconds:.1f} s"
)

summary = pd.DataFrame(post.statistics()).T
print(summary.round(4).astype({"ess": int}))

# %%
# ``log_sigma_i`` is the log of tendon :math:`i`'s load-cell noise in N: its posterior sits at
# :math:`\ln 1 = 0`, the simulator's 1 N. The 95 % interval of :math:`\mu_i(0)`:

mu0 = post.mu0_samples()[:, 0]  # (draws, 3)
lo, hi = np.percentile(mu0, [2.5, 97.5], axis=0)
for i in range(3):
    inside = lo[i] <= A_true[i] + B_true[i] <= hi[i]
    print(f"tendon {i + 1}: mu(0) in [{lo[i]:.4f}, {hi[i]:.4f}], true {A_true[i] + B_true[i]:.4f}, covered: {inside}")

# %%
# The corner plot shows the law parameters (the noise parameters are left out). :math:`A_i` and
# :math:`B_i` are strongly anti-correlated along :math:`A_i + B_i = \mu_i(0)`, and the constraint
# :math:`B_i \ge |A_i|` cuts the ridge.

fig = post.corner(truths=[*np.ravel(np.column_stack([A_true, B_true])), 0.0, 0.0, 0.0])
fig.set_size_inches(10, 10)
plt.show()

# %%
# The same draws as an ArviZ ``InferenceData`` (one chain per walker): effective sample sizes
# and split R-hat come from ArviZ.

idata = post.to_arviz()
print(az.summary(idata, round_to=4))

# %%
# Posterior-predictive bands at joints without a sensor
# -----------------------------------------------------
#
# Each posterior draw of the law is propagated through the cascade of guides:
# :meth:`~tendon_id.calibration.law_posterior.PosteriorResult.predictive_bands` returns the 2.5, 50 and 97.5
# percentiles of :math:`T[j, j, i]` for every joint (parameter uncertainty only; the load-cell
# noise is not added). The simulator's intermediate truth, never seen in fitting, checks them.

bands = post.predictive_bands(model, test)
truth_joint = test.joint_truth  # (T, N, 3): simulator truth, never seen in fitting

# The bands hold the law's uncertainty only. The estimate also carries the noise of the
# actuator-side load cell it starts from, scaled by the transmission ratio of the chain:
# add it (posterior mean of sigma_i) to get a band for what the estimate can be off by.
sigma = np.exp(summary.loc[["log_sigma_1", "log_sigma_2", "log_sigma_3"], "mean"].to_numpy(dtype=float))
ratio = bands["median"] / test.actuator  # T[j, j, i] / T[1, j, i]
half = np.hypot((bands["hi"] - bands["lo"]) / 2, 1.96 * sigma * ratio)
lo_tot, hi_tot = bands["median"] - half, bands["median"] + half

frames = slice(0, 400)
t = np.arange(test.n_frames)[frames]
fig, axes = plt.subplots(2, 2, figsize=(10, 6), sharex=True, layout="constrained")
for row, j in enumerate((4, 8)):
    k = j - 1
    ax = axes[row, 0]
    ax.fill_between(
        t, bands["lo"][frames, k, 0], bands["hi"][frames, k, 0], color="C0", alpha=0.5, label="95 % posterior band"
    )
    ax.plot(t, truth_joint[frames, k, 0], color="k", lw=0.8, ls="--", label="simulator truth")
    ax.set_ylabel(f"$T[{j},{j},1]$ [N]")
    ax.set_title(f"joint {j}, tendon 1")
    ax = axes[row, 1]  # the same, relative to the truth
    ax.fill_between(
        t,
        (lo_tot - truth_joint)[frames, k, 0],
        (hi_tot - truth_joint)[frames, k, 0],
        color="C1",
        alpha=0.3,
        label="band + input noise",
    )
    ax.fill_between(
        t,
        (bands["lo"] - truth_joint)[frames, k, 0],
        (bands["hi"] - truth_joint)[frames, k, 0],
        color="C0",
        alpha=0.8,
        label="95 % posterior band",
    )
    ax.axhline(0.0, color="k", lw=0.8, ls="--")
    ax.set_ylabel("minus truth [N]")
    ax.set_title(f"joint {j}, tendon 1, relative to the truth")
axes[0, 0].legend(fontsize=8, loc="upper right")
axes[0, 1].legend(fontsize=8, loc="upper right")
for ax in axes[1]:
    ax.set_xlabel("test frame")
plt.show()

# %%
# At the scale of the tension (left) the posterior band is a line, a few hundredths of a newton
# wide. Relative to the truth (right) it is clear that the law no longer limits the estimate: the
# 1 N noise of the actuator-side load cell, carried down the chain, does. The posterior band
# widens towards the tip, as the uncertainty of :math:`\mu_i(0)` compounds guide after guide.

width = bands["hi"] - bands["lo"]
inside = (bands["lo"] <= truth_joint) & (truth_joint <= bands["hi"])
inside_tot = (lo_tot <= truth_joint) & (truth_joint <= hi_tot)
for j in (4, 8, 11):
    k = j - 1
    print(
        f"joint {j:2d}, tendon 1: posterior band {np.median(width[:, k, 0]):.3f} N wide, covers the truth in "
        f"{inside[:, k, 0].mean() * 100:3.0f} % of frames; with the input noise "
        f"{np.median(2 * half[:, k, 0]):.2f} N wide, {inside_tot[:, k, 0].mean() * 100:3.0f} %"
    )

score = model.score(test)
print(
    f"test: terminal RMSE {score['terminal']['rmse']:.2f} N, "
    f"intermediate joints 2-11 RMSE {score['joints']['overall']['rmse']:.2f} N"
)

# %%
# Misspecification
# ----------------
#
# ``snake12-paper`` switches on what the capstan models do not fully know: a viscoelastic lag in
# every guide, per-tendon wraps, and stick/slip whose state carries over from the unlogged motion
# between logged trajectories (the model starts every trajectory in forward slip). Its friction law
# is the paper's, with :math:`\mu_i(0) \approx 0.39`. We calibrate the contact-gated capstan and
# the nonsmooth capstan (contact gate plus hysteresis, multi-start COBYLA) on 70 % of the
# ``posterior-3`` trajectories and score them on the rest.

rec_p = tendon_id.sim.simulate(
    tendon_id.datasets.load_recipe("snake12-paper"), "posterior-3", frames=2000, seed=0
).recording
train_p, test_p = rec_p.split((0.7, 0.3), seed=0)
print("effects:", rec_p.meta["effects"])

rows = {}
fitted = {}
for name in ("proximal", "capstan-contact", "capstan-nonsmooth"):
    m = zoo.make(name).fit(train_p)
    fitted[name] = m
    s = m.score(test_p)
    rows[name] = {
        "terminal RMSE [N]": s["terminal"]["rmse"],
        "terminal R2": s["terminal"]["r2"],
        "joints 2-11 RMSE [N]": s["joints"]["overall"]["rmse"],
        "joints 2-11 R2": s["joints"]["overall"]["r2"],
        "mu0 (mean of 3)": float(np.mean(m.mu0_)) if name != "proximal" else float("nan"),  # proximal has no law
    }
print(pd.DataFrame(rows).T.round(3))

# %%
# Both models beat the proximal estimate, and the nonsmooth model beats the contact-only one, but
# neither is good: the terminal :math:`R^2` is negative on the test trajectories, and the
# calibrated :math:`\mu_i(0)` is a fraction of the true 0.39. With terminal-only labels the
# optimiser bends the law to absorb the missing lag and the unknown initial stick state, so a
# well-converged fit and a tight posterior of a misspecified model are not evidence that the law
# is right. Intermediate joints, which only the simulator can score, show the damage along the
# whole chain:

per_joint = {
    name: [mj["rmse"] for mj in fitted[name].score(test_p)["joints"]["per_joint"]]
    for name in ("proximal", "capstan-contact", "capstan-nonsmooth")
}
fig, ax = plt.subplots(figsize=(7, 3.5), layout="constrained")
joints = np.arange(1, rec_p.n_modules + 1)
for name, values in per_joint.items():
    ax.plot(joints, values, marker="o", label=name)
ax.set_xlabel("joint $j$")
ax.set_ylabel("RMSE of $T[j, j, :]$ [N]")
ax.set_xticks(joints)
ax.set_title("snake12-paper, posterior-3 test trajectories")
ax.legend(fontsize=8)
plt.show()

print(f"example ran in {time.perf_counter() - t_start:.1f} s")

# %%
# The gap has a structure: the simulator's effects each leave a signature (see
# :doc:`../guide/simulator`), and :meth:`~tendon_id.zoo.CapstanModel.with_blocks` adds the
# matching effect block to a model, e.g.
# ``zoo.make("capstan-nonsmooth").with_blocks("viscoelastic")``, whose lag parameters are then
# calibrated with the law.
