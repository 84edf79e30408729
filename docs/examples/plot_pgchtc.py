"""
Train PG-CHTC and compare it with the capstan baseline
=======================================================

PG-CHTC learns one tension-ratio law shared by every guide, regularised by the capstan
prior, from terminal-only labels (paper Section III).  Here we train it with the ``fast``
preset on the paper's training split of the ``snake12-paper`` recipe, calibrate the
``capstan-nonsmooth`` baseline on the same data, and compare both on held-out
trajectories, at the terminal joint (what the paper measured) and at the intermediate
joints (which only the simulator can tell).
"""

# %%
# The paper's split (Section IV-B): a 23 000-frame pool of terminal-only, posterior-3 and
# posterior-6 trajectories for training, and held-out posterior-3, posterior-6 and
# planned-path trajectories for testing.  Planned paths are never seen in training.
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

from tendon_id import zoo
from tendon_id.benchmarks.splits import paper_split
from tendon_id.report.comparison import estimates_figure, per_joint_rmse_figure

split = paper_split("snake12-paper", seed=0)
print(f"train {split.train.n_frames} frames, validation {split.val.n_frames} frames")
print({p: r.n_frames for p, r in split.test.items()})

# %%
# Fit both models.  ``fit`` only ever sees the terminal labels: the intermediate truth
# columns are dropped before anything is read.
baseline = zoo.make("capstan-nonsmooth").fit(split.calibration)
pgchtc = zoo.make("pg-chtc", preset="fast", progress=False).fit(split.calibration)
print("prior law (A, B) per tendon:", np.round(pgchtc.prior_A_, 3), np.round(pgchtc.prior_B_, 3))
print("stage 1 epochs:", len(pgchtc.history_["stage1"]), " stage 2 epochs:", len(pgchtc.history_["stage2"]))

# %%
# Terminal and intermediate-joint RMSE on every held-out protocol.
for protocol, rec in split.test.items():
    for name, model in (("capstan-nonsmooth", baseline), ("PG-CHTC", pgchtc)):
        s = model.score(rec)
        print(
            f"{protocol:14s} {name:18s} terminal RMSE {s['terminal']['rmse']:6.1f} N   "
            f"intermediate joints {s['joints']['overall']['rmse']:6.1f} N"
        )

# %%
# Error at every joint: the cascade's shared law keeps the intermediate estimates close to
# the truth although it never saw them.
fig = per_joint_rmse_figure(
    {"capstan-nonsmooth": baseline.score(split.test["posterior-6"]), "PG-CHTC": pgchtc.score(split.test["posterior-6"])}
)
plt.show()

# %%
# Estimates against truth on one held-out planned path.
rec = split.test["planned-paths"].select([split.test["planned-paths"].trajectories[0]])
fig = estimates_figure(rec, {"capstan-nonsmooth": baseline.predict(rec), "PG-CHTC": pgchtc.predict(rec)})
plt.show()

# %%
# The same model runs frame by frame with causal caches, as a controller would use it,
# and agrees with batch inference.
stream = pgchtc.streamer()
online = np.stack([stream.step(rec.angles[t], rec.actuator[t]) for t in range(rec.n_frames)])
print("max relative difference, streaming vs batch:", float(np.max(np.abs(online / pgchtc.predict(rec) - 1))))
