"""
The estimator in closed loop: a step on the simulated robot
===========================================================

The paper's last experiment (Section IV-C, Table III, Fig. 6) puts the tension estimator inside
a 10 Hz hybrid tension and configuration controller and compares how fast the joints settle
after a step. This example runs one such step on the simulated ``snake12-paper`` robot with
three estimators:

* the **oracle**, which reads the true joint-side tension (a load cell at every joint),
* **capstan-nonsmooth**, the paper's calibrated physics baseline,
* **proximal**, no compensation at all: the actuator-side tension is taken for the joint side.

The learned cascades take minutes to train, so they are left to
``tendon-id benchmark table3`` (see :doc:`../guide/closed_loop`).
"""

# %%
# Fit the estimators on logged data
# ---------------------------------
#
# The estimators are fitted on open-loop logs of the usual protocols, never on a closed-loop
# run. A small posterior-3 pool keeps this example quick.

import time

import matplotlib.pyplot as plt
import numpy as np

from tendon_id.closed_loop import STEP_TESTS, in_loop, loop_metrics, run_step_test
from tendon_id.datasets import load_recipe
from tendon_id.report.closed_loop import step_figure
from tendon_id.sim import simulate
from tendon_id.zoo import make

t_start = time.perf_counter()
recipe = load_recipe("snake12-paper")
logs = simulate(recipe, "posterior-3", frames=2000, seed=1).recording
models = {name: make(name).fit(logs) for name in ("capstan-nonsmooth", "proximal")}

# %%
# Close the loop
# --------------
#
# Each estimator drives its own robot: joint dynamics integrated at 1 kHz through the recipe's
# truth transmission (contact, stick/slip, viscoelastic lag, per-tendon wraps), with the same
# controller gains (tuned once for the oracle) and the same sensor noise. Every tendon that
# crosses a joint pulls on it, so the controller feeds forward the load of the distal sets'
# tendons at each joint they pass through, at the estimator's tensions there. The test bends
# joints 10-12 by 5 degrees and back (the paper's Posterior-3 regime).

test = STEP_TESTS["posterior-3"]
estimators = [in_loop("oracle"), *(in_loop(name, model, recipe.dt) for name, model in models.items())]
run = run_step_test(recipe, estimators, test, seed=0)
for b, name in enumerate(run.estimators):
    for loop in (1, 2):
        m = loop_metrics(run, b, loop)
        settle = "never" if m["settle_s"] is None else f"{m['settle_s']:.1f} s"
        rise = "never" if m["rise_s"] is None else f"{m['rise_s']:.2f} s"
        print(f"{name:18s} loop {loop}: rise {rise:>7s}, settle {settle:>7s}, RMS {m['rms_deg']:.2f} deg")

# %%
# The step responses, as in the paper's Fig. 6
# --------------------------------------------
#
# Both bending axes of the three stepped joints. The uncompensated and the capstan-driven
# controllers reach the band later: their joint-side estimates are biased, and the outer
# loop's integrator has to make up what the inner loop got wrong.

rows = [
    {"regime": test.regime, "estimator": name, "loop": loop, **loop_metrics(run, b, loop)}
    for b, name in enumerate(run.estimators)
    for loop in (1, 2)
]
fig = step_figure({test.regime: run.traces()}, test.regime, rows)
plt.show()

# %%
# Why: the estimators' errors during the run
# ------------------------------------------
#
# The controller can only be as good as its estimate of the joint side. The RMS error of each
# estimate at the stepped joints, against the simulator's truth, and of its intermediate
# estimates: every set's tension at the joints it passes through (``k < j``), the ones the
# controller feeds forward and terminal-only supervision never sees.

idx = np.asarray(test.joints) - 1
passing = np.triu(np.ones((12, 12), dtype=bool), k=1)  # T[k, j] with k < j
for b, name in enumerate(run.estimators):
    err = run.estimate[b][:, idx] - run.joint_side[b][:, idx]
    chain_err = (np.nan_to_num(run.chain_estimate[b]) - run.chain[b])[:, passing]
    print(
        f"{name:18s} joint-side error {np.sqrt(np.mean(err**2)):6.1f} N (bias {np.mean(err):+6.1f} N), "
        f"intermediate {np.sqrt(np.mean(chain_err**2)):6.1f} N"
    )
print(f"example ran in {time.perf_counter() - t_start:.0f} s")
