"""
A real bench: calibrating and diagnosing a da Vinci instrument's cable transmission
===================================================================================

Everything else in this gallery runs on our simulator. This example runs on **real** bench
recordings: the cable transmission of a da Vinci Si instrument (Maryland bipolar forceps,
``Tool_4_Maryland_L_2``), driven by a sine on its input spindle against a spring load on its
jaw, with a torque sensor and an encoder at each end, at 1 kHz. Twenty files: five sine
frequencies (the first digit of ``XY.TXT``) times four load levels (the second).

The data is the MRDLab ``mis-tool-characterization`` set (Medical Robotics and Devices Lab,
University of Minnesota; github.com/MRDLab/mis-tool-characterization), published with

    J. J. O'Neill, T. K. Stephens and T. M. Kowalewski, "Evaluation of Torque Measurement
    Surrogates as Applied to Grip Torque and Jaw Angle Estimation of Robotic Surgical Tools",
    *IEEE Robotics and Automation Letters* 3(4):3027-3034, 2018, doi:10.1109/LRA.2018.2849862,

under the Open Database License (ODbL 1.0) and the Database Contents License (DbCL 1.0).
tendon-id ships only a *mapping* of its file format (``datasets/mappings/mis-tool-characterization.toml``),
never the data: this example reads it from ``../shared/data/real/`` beside the project (or from
the folder named by the environment variable ``TENDON_ID_BENCH``), and says so and stops where it
is absent.

The steps: read the files through the mapping, hold out half the files, calibrate the capstan
passage with nlopt, diagnose what it leaves out, and compare measured and predicted hysteresis
loops on held-out files. See :doc:`../guide/data` (mappings) and :doc:`../guide/diagnosis`.
"""

# %%
# Read the bench through its mapping
# ----------------------------------
#
# The mapping names the columns of the bench's headerless files, their units (encoder counts,
# sensor counts with a scale) and signs; :func:`~tendon_id.data.mapping.read_files` converts
# every column to SI once, on reading. The files are split **by file**: those whose two digits
# sum to an even number are for fitting, the other ten are held out, so every frequency and
# every load level is seen in both halves.

import os
import time
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from tendon_id import zoo
from tendon_id.data.mapping import load_mapping, read_files
from tendon_id.datasets import mapping_path
from tendon_id.diagnosis import DiagnosisSettings, diagnose

t_start = time.perf_counter()
here = Path(__file__).resolve().parent if "__file__" in globals() else Path.cwd()
default = here.parents[2] / "shared" / "data" / "real" / "mis-tool-characterization" / "Tool_4_Maryland_L_2"
bench = Path(os.environ.get("TENDON_ID_BENCH", default))
files = sorted(bench.glob("[0-9][0-9].TXT"))
if not files:
    print(f"The bench data is not here ({bench}): this example needs ../shared/data/real/ and stops.")
else:
    mapping = load_mapping(mapping_path("mis-tool-characterization"))
    recordings = dict(zip((f.stem for f in files), read_files(files, mapping)))
    train = [r for k, r in recordings.items() if (int(k[0]) + int(k[1])) % 2 == 0]
    test = [r for k, r in recordings.items() if (int(k[0]) + int(k[1])) % 2 == 1]
    print(f"{len(train)} files for fitting, {len(test)} held out, {sum(r.n_frames for r in train)} frames to fit")

# %%
# Calibrate with nlopt
# --------------------
#
# ``passage-capstan`` predicts the jaw torque from the spindle torque through an antagonistic
# cable pair, each cable attenuated by :math:`e^{\mp\mu\alpha}` in its slip direction (the
# paper's Eq. (6)); the ``stick_slip`` block holds the output between the two slip edges
# through reversals (the play operator). The fit is a bounded least squares solved by nlopt's
# SLSQP. The correlations of its Jacobian tell what the data can and cannot pin: here the
# pair's gain, exponent, pretension and sharing move together along a ridge (correlation
# above 0.99), so only their combination, the two slip edges, is determined by torques alone.

if files:
    from tendon_id.zoo.passage.fitting import confounded_groups

    model = zoo.make("passage-capstan", blocks=["stick_slip"]).fit(train)
    print({k: round(v, 4) for k, v in model.theta_.items()})
    print("status:", model.calibration_["status"], f"training RMSE {model.calibration_['rmse']:.4f} N m")
    print(
        "the data pins only the combination of:",
        confounded_groups(list(model.theta_), model.calibration_["correlation"]),
    )
    print(f"held-out RMSE {model.score(test)['predicted']['rmse']:.4f} N m")

# %%
# Diagnose the base on held-out files
# -----------------------------------
#
# The diagnosis refits the memoryless base (``passage-capstan`` without blocks) with each
# candidate block, ranks them by held-out RMSE, tests each improvement with a block bootstrap
# over time, and climbs a ladder of significant effects. Three candidates keep this example
# short: the command ``tendon-id diagnose --base passage-capstan --mapping
# mis-tool-characterization`` tries all eight (the cable's elasticity, the input cell's gain and
# offset and a clock skew among them), and on this split climbs ``stick_slip`` (0.00484 N m) then
# ``smooth_edge`` (slip spreading along the wrap, 0.00348 N m; :doc:`/guide/diagnosis`).

if files:
    result = diagnose(
        zoo.make("passage-capstan"),
        train,
        test,
        ["stick_slip", "velocity_friction", "position_torque"],
        settings=DiagnosisSettings(n_boot=200),
        progress=False,
    )
    print(result.summary())

# %%
# The ladder, as a figure: the held-out RMSE of the base and of each accepted rung.

if files:
    rungs = result.ladder
    fig, ax = plt.subplots(figsize=(6.4, 2.6), layout="constrained")
    names = ["base"] + ["+ " + r.effects[-1] for r in rungs[1:]]
    ax.barh(names[::-1], [r.heldout_rmse * 1e3 for r in rungs][::-1], color="tab:blue")
    ax.axvline(result.noise_floor * 1e3, color="k", ls=":", label="noise floor")
    ax.set_xlabel("held-out RMSE [mN m]")
    ax.legend(loc="lower right")

# %%
# Loops of measured against predicted
# -----------------------------------
#
# Output against input torque on a held-out file: the measured loop opens at every reversal
# (the friction's band); the memoryless base jumps across it at once, the ladder's model
# holds the output through the band as the measured one does.

if files:
    from tendon_id.zoo.passage import PassageInputs

    base = zoo.make("passage-capstan").fit(train)
    final = result.model
    inputs = PassageInputs.from_recordings(recordings["12"])  # held out: 1 + 2 is odd
    keep = inputs.since_start >= 1.0
    fig, axes = plt.subplots(1, 2, figsize=(9, 3.6), sharey=True, layout="constrained")
    for ax, m, label in [(axes[0], base, "base"), (axes[1], final, "ladder: " + " + ".join(final.blocks))]:
        ax.plot(inputs.input[keep], inputs.output[keep], color="0.6", lw=0.8, label="measured")
        ax.plot(inputs.input[keep], m.predict(inputs)[keep], color="tab:red", lw=0.8, label="predicted")
        ax.set_title(
            f"{label}\nheld-out RMSE {np.sqrt(np.mean((m.predict(inputs) - inputs.output)[keep] ** 2)) * 1e3:.2f} mN m"
        )
        ax.set_xlabel("input (spindle) torque [N m]")
    axes[0].set_ylabel("output (jaw) torque [N m]")
    axes[0].legend()
    print(f"example ran in {time.perf_counter() - t_start:.0f} s")

# %%
# The posterior
# -------------
#
# ``tendon-id calibrate --model passage-capstan --mapping mis-tool-characterization
# --blocks stick_slip --posterior --data ... --out cal/`` samples the posterior of the law with
# emcee (:mod:`tendon_id.zoo.passage.likelihood`). At 1 kHz the residual of the fit stays
# correlated for about a second, so the likelihood counts the effective frames, not the frames:
# the posterior is wide along the ridge above, which is what torque measurements alone can tell.
