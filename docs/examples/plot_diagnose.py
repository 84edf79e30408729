"""
Why does my model disagree with my robot? Diagnosing a withheld effect
======================================================================

A calibrated capstan model misses something the robot does. This example simulates such a
robot, one whose tendons relax viscoelastically, gives the diagnosis the paper's baseline
(``capstan-nonsmooth``, which has no lag), and reads its three answers: where the gap lies,
which unmodelled effect causes it, and how far the gap shrinks once that effect is added.
See :doc:`../guide/diagnosis` for the method.
"""

# %%
# A robot with an effect the model leaves out
# -------------------------------------------
#
# A case of the withheld-effect benchmark: ``snake12-paper``'s robot with a friction law the
# baseline can represent (``snake12-noise-only``'s), contact and stick/slip (the baseline's
# own structure), plus a viscoelastic lag at its documented default (``tau_v = 1.5 s``,
# ``kappa = 0.04`` per guide). Training and test data are independent runs of held poses (the
# paper's posterior-6 protocol) and planned paths.

import matplotlib.pyplot as plt

from tendon_id import zoo
from tendon_id.benchmarks.withheld import Case, case_data
from tendon_id.diagnosis import diagnose
from tendon_id.report.diagnosis import gap_map_figure, ladder_figure

case = Case("single", ("viscoelastic",), "default", seed=0, frames=1000)
train, test = case_data(case)
base = zoo.make("capstan-nonsmooth").fit(train)
print(f"base fitted on {sum(r.n_frames for r in train)} frames; test: {sum(r.n_frames for r in test)} frames")

# %%
# The diagnosis
# -------------
#
# Every candidate block is added to the base, refitted from the base's fit, and scored on the
# held-out data; the ladder keeps adding the best one while the improvement is significant.

result = diagnose(base, train, test, progress=False)
print(result.summary())

# %%
# Where the gap lies
# ------------------
#
# Red bars longer than grey ones mark where the error concentrates: here, while the joints move
# (68 % of the squared error in the 43 % of frames that are not at rest), as a lag would, and
# when the distal guides 7-11 are bent (43-44 % of it in a quarter of the frames each, with a
# bias of -1.4 to -1.7 N: the measured tension lags below what the base predicts).

gap_map_figure(result)
plt.show()

# %%
# How far it shrinks
# ------------------
#
# The ladder: the held-out RMSE after each added effect, against the noise floor (the
# load-cell noise plus what the model inherits from the actuator cells).

ladder_figure(result)
plt.show()

fitted = result.candidates[0]
print(f"{fitted.effect}: {fitted.params}  (truth: tau_v = 1.5 s, kappa = 0.04)")
print(f"verdict: {result.verdict.kind}, gap left {result.verdict.remaining:.0%}")

# %%
# The improved model is an ordinary fitted zoo model: save it, evaluate it, stream with it.

print(result.model.block_objects)
