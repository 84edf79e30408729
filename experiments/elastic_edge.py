"""A reversal: the edge of the friction band against actuator displacement, beside the bench's.

Usage: python experiments/elastic_edge.py [--bench DIR] [--out docs/_static/elastic_edge.png]
       [--json docs/_static/elastic_edge.json]

A rigid play operator crosses the friction band at once when its input reverses; an elastic
tendon (``stick_slip.driver = "elastic"``, :mod:`friction_models.elastic_chain`) needs actuator
displacement to cross it, so plotted against the actuator's travel its edge is rounded.  This
script draws the two edges side by side.

(a) Bench.  The MRDLab da Vinci instrument bench (O'Neill, Stephens & Kowalewski, "Evaluation of
torque measurement surrogates as applied to grip torque and jaw angle estimation of robotic
surgical tools", IEEE RA-L 3(4):3027-3034, 2018; github.com/MRDLab/mis-tool-characterization,
ODbL 1.0 / DbCL 1.0; read in place from ``../shared``, never copied): the 20 files
``Tool_4_Maryland_L_2/*.TXT``, read with the project's own mapping
(``read_files(paths, load_mapping(mapping_path("mis-tool-characterization")))``: input = spindle
torque, output = jaw torque, position = spindle angle, 1 kHz).

* Reversals: the spindle angle is smoothed by a 31-sample (31 ms) moving mean; a reversal is a
  turning point of the smoothed angle, accepted once the angle has gone back by more than 5 deg
  from it (a zig-zag filter, so the encoder's 0.044 deg steps at the slow turns give no false
  sign changes of the rate).  A reversal is used if the spindle then travels at least 25 deg
  before the next one and approached it over at least 1 deg.
* Travel ``x``: the spindle angle travelled since the reversal [deg], from the smoothed angle,
  made monotone by a running maximum.
* Signal: the spindle (input) torque, lightly smoothed (5-sample moving mean).  It is the right
  signal here: the jaw is held by a torque-controlled load motor, so the output torque stays
  almost constant through a reversal (it changes by a few mN m between the two directions, with
  no edge of its own) while the input torque swings across the whole friction band (about 100
  mN m).  The input-minus-output torque gives the same numbers to within a few hundredths of a
  degree (stored in the JSON as a check).
* Band fraction: ``u(x) = (tau_rev - tau(x)) / (tau_rev - L(x))``, where ``tau_rev`` is the
  torque on the old sliding branch at the reversal (the median of the torque over the last
  0.1-1.0 deg of the approach, so it does not depend on which sample of the flat turn is called
  the reversal) and ``L`` is the new sliding branch: a straight line in the angle fitted to the
  torque over 10-25 deg of travel after the reversal, extrapolated back.  ``u = 0`` on the old
  branch, ``u = 1`` where the torque has joined the new one; the end of the transition is where
  the torque meets the new branch's line, which takes the branch's own slope (the bench's
  position torque) out of the band.  The line is a simple, robust stand-in for "where the slope
  settles to the sliding slope"; the JSON also gives the numbers with fit windows 5-15 and
  15-30 deg.
* Reported: the travel at which ``u`` first reaches 0.5 and 0.9, per reversal; the median and
  range over reversals, and the median curve (median of ``u`` over reversals on a common grid).

(b) Simulator.  One tendon (set 12, tendon 1: it passes all 11 guides) of ``snake12-elastic`` at
a fixed pose: every joint at 5 deg about its first axis (0 about the second), so each guide's
wrap is 0.137 rad.  Its capstan exponents ``phi`` come from the recipe's own friction law at that
pose through :func:`tendon_id.sim.transmission.guide_terms`: ``phi = mu(alpha) max(alpha -
alpha_c, 0)`` with the recipe's law ``mu = A cos(alpha) + B`` (A = 0.30, B = 0.09 for tendon 1),
``alpha_c = 0.03 rad`` (dead-zone contact) and the exact wraps, i.e. 0.387 * 0.107 = 0.0415 per
guide, 0.457 in all, so the band of the actuator tension at 200 N is 200 -> 200 e^{-2 * 0.457} =
80.2 N.  The actuator tension ``T_0`` is driven as a triangle 80 -> 200 -> 80 N in 0.01 N steps
(``elastic_chain``, the reference solver, ``dL = 0``: fixed pose; no viscoelasticity, which
the recipe does not enable).  Stiffnesses: ``k_s = EA / (link_length + joint_gap) = EA / 0.07 m``
for the segments between guides (the simulator's :func:`segment_length`) and ``k_0 = EA / l_0``
with ``l_0 = 0.5 m`` for segment 0, from the actuator to guide 1 (a remote actuation pack).

* Actuator displacement after the reversal (tendon paid out by the actuator) [mm]:
  ``x = (T_0(rev) - T_0) / k_0 + sum_s (T_s(rev) - T_s) / k_s`` (the change of the stretch of
  every segment; the pose and so every path length is fixed).
* Band fraction: ``u = (T_0(rev) - T_0) / (T_0(rev) - T_0*)``, ``T_0*`` the actuator tension at
  which the joint-side tension ``T_11`` starts to move (first drops below its value at the
  reversal by more than 1e-6 N).
* With the tension driver and a fixed pose the tensions along the chain do not depend on the
  stiffness (each guide is a play operator in turn); only ``x`` does, as ``1 / EA``.  EA = 3.5e4 N
  (the recipe), 3.5e5 N (10x stiffer) and 3.5e3 N (10x softer); the rigid tendon is the vertical
  line ``x = 0``.

Runtime: about 18 s (12 s CPU) on the shared 2-core machine.  Skips (exit 0) when the bench data are absent.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
BENCH = ROOT.parent / "shared" / "data" / "real" / "mis-tool-characterization"
FOLDER = "Tool_4_Maryland_L_2"
CITATION = (
    "Bench: O'Neill, Stephens & Kowalewski, IEEE RA-L 3(4):3027–3034, 2018; "
    "github.com/MRDLab/mis-tool-characterization, ODbL 1.0 / DbCL 1.0 (Tool_4_Maryland_L_2, 20 files, read in place)."
)

SMOOTH_ANGLE = 31  # samples (1 kHz)
SMOOTH_TORQUE = 5
TURN_DEG = 5.0  # zig-zag threshold
FIT_WINDOW = (10.0, 25.0)  # deg of travel: the new sliding branch
APPROACH = (0.1, 1.0)  # deg before the reversal: the old branch's torque at the reversal
LEVELS = (0.5, 0.9)
GRID = np.linspace(0.0, 12.0, 1201)  # deg


def moving_mean(a, n):
    from scipy.ndimage import uniform_filter1d

    return uniform_filter1d(np.asarray(a, float), n, mode="nearest")


def turning_points(a, h):
    """Indices of the turning points of ``a``, each accepted once ``a`` has gone back by more than ``h``."""
    out, ext, d = [], 0, 0
    for k in range(1, len(a)):
        if d == 0:
            if abs(a[k] - a[0]) > h:
                d, ext = (1 if a[k] > a[0] else -1), k
            continue
        if (d > 0 and a[k] > a[ext]) or (d < 0 and a[k] < a[ext]):
            ext = k
        elif abs(a[k] - a[ext]) > h:
            out.append(ext)
            d, ext = -d, k
    return out


def first_crossing(x, u, level):
    """Travel at which ``u`` first reaches ``level`` (linear interpolation between samples)."""
    k = np.flatnonzero(u >= level)
    if k.size == 0:
        return np.nan
    k = k[0]
    if k == 0:
        return float(x[0])
    return float(np.interp(level, [u[k - 1], u[k]], [x[k - 1], x[k]]))


def reversal_edges(angle_deg, torque, fit=FIT_WINDOW):
    """Per reversal: (travel [deg], band fraction u, direction) after it."""
    a = moving_mean(angle_deg, SMOOTH_ANGLE)
    tq = moving_mean(torque, SMOOTH_TORQUE)
    turns = turning_points(a, TURN_DEG)
    edges = []
    for n, j in enumerate(turns):
        end = turns[n + 1] if n + 1 < len(turns) else len(a)
        start = turns[n - 1] if n > 0 else 0
        d = 1.0 if a[end - 1] > a[j] else -1.0  # direction of travel after the reversal
        travel = np.maximum.accumulate(d * (a[j:end] - a[j]))
        if travel[-1] < fit[1]:
            continue
        before = d * (a[start:j] - a[j])  # distance to the reversal on the approach (>= 0)
        appr = (before >= APPROACH[0]) & (before <= APPROACH[1])
        if before.size == 0 or before.max() < APPROACH[1] or appr.sum() < 10:
            continue
        tau_rev = float(np.median(tq[start:j][appr]))
        y = tq[j:end]
        sel = (travel >= fit[0]) & (travel <= fit[1])
        slope, icpt = np.polyfit(travel[sel], y[sel], 1)
        line = icpt + slope * travel
        u = (tau_rev - y) / (tau_rev - line)
        edges.append((travel, u, d))
    return edges


def bench(folder: Path) -> dict:
    from tendon_id.data.mapping import load_mapping, read_files
    from tendon_id.datasets import mapping_path

    paths = sorted(folder.glob("*.TXT"))
    recs = read_files(paths, load_mapping(mapping_path("mis-tool-characterization")))
    curves, cross, check = [], [], []
    alt = {"5-15": (5.0, 15.0), "15-30": (15.0, 30.0)}
    alt_cross = {k: [] for k in alt}
    for r in recs:
        ang = np.degrees(np.asarray(r.frame["position"], float))
        tin = np.asarray(r.input, float) * 1e3  # mN m
        tout = np.asarray(r.output, float) * 1e3
        for travel, u, d in reversal_edges(ang, tin):
            curves.append((travel, u, d))
            cross.append([first_crossing(travel, u, lv) for lv in LEVELS] + [d])
        for travel, u, _ in reversal_edges(ang, tin - tout):
            check.append([first_crossing(travel, u, lv) for lv in LEVELS])
        for k, w in alt.items():
            for travel, u, _ in reversal_edges(ang, tin, fit=w):
                alt_cross[k].append([first_crossing(travel, u, lv) for lv in LEVELS])
    cross = np.array(cross)
    grid_u = []
    for travel, u, _ in curves:
        t, i = np.unique(travel, return_index=True)
        grid_u.append(np.interp(GRID, t, u[i]))
    med = np.median(np.array(grid_u), axis=0)

    def summary(c):
        c = np.asarray(c)
        return {
            f"{int(lv * 100)}%": {
                "median_deg": float(np.nanmedian(c[:, k])),
                "range_deg": [float(np.nanmin(c[:, k])), float(np.nanmax(c[:, k]))],
                "p10_p90_deg": [float(np.nanpercentile(c[:, k], 10)), float(np.nanpercentile(c[:, k], 90))],
            }
            for k, lv in enumerate(LEVELS)
        }

    out = {
        "files": len(recs),
        "reversals": len(curves),
        "input_torque": summary(cross[:, :2]),
        "by_direction": {
            "angle_rising_after": summary(cross[cross[:, 2] > 0, :2]),
            "angle_falling_after": summary(cross[cross[:, 2] < 0, :2]),
        },
        "check_input_minus_output": summary(check),
        "fit_window_sensitivity": {k: summary(v) for k, v in alt_cross.items()},
        "median_curve_crossing_deg": [first_crossing(GRID, med, lv) for lv in LEVELS],
    }
    return {"summary": out, "curves": curves, "median": med}


def simulator() -> dict:
    from friction_models import SLACK_FLOOR_N
    from friction_models.elastic_chain import elastic_chain
    from tendon_id.datasets import load_recipe
    from tendon_id.sim.transmission import GuideWraps, guide_terms, wear_factors
    from tendon_id.sliding import segment_length

    rec = load_recipe("snake12-elastic")
    geo, eff = rec.robot, rec.effects
    n = geo.n_modules
    theta = np.zeros((1, n, 2))
    theta[..., 0] = np.radians(5.0)
    wraps = GuideWraps(theta, geo, eff)
    wear = wear_factors(geo, eff)
    j, i = n - 1, 0  # set 12 (passes guides 1..11), tendon 1
    alpha, phi = np.empty(n - 1), np.empty(n - 1)
    for g in range(n - 1):
        a, p = guide_terms(g, wraps, rec.friction, eff, None, wear)
        alpha[g], phi[g] = a[0, j - g - 1, i], p[0, j - g - 1, i]
    step = 0.01
    up = np.arange(80.0, 200.0, step)
    down = np.arange(200.0, 80.0 - step / 2, -step)
    t0 = np.concatenate([up, down])
    rev = len(up)
    frames = len(t0)
    l_seg, l_0 = segment_length(geo), 0.5
    ea_recipe = float(eff.get("stick_slip").EA)
    runs = {}
    for label, ea in (("10x stiffer", 10 * ea_recipe), ("recipe", ea_recipe), ("10x softer", ea_recipe / 10)):
        k = np.full(n - 1, ea / l_seg)
        reset = np.zeros(frames, bool)
        reset[0] = True
        tension, _ = elastic_chain(
            t0, np.zeros((frames, n - 1)), np.tile(phi, (frames, 1)), k, reset, floor=SLACK_FLOOR_N
        )
        tt, ts = t0[rev:], tension[rev:]
        moved = np.flatnonzero(ts[:, -1] < ts[0, -1] - 1e-6)
        t_star = tt[moved[0] - 1] if moved.size else np.nan
        x_mm = 1e3 * ((tt[0] - tt) / (ea / l_0) + ((ts[0] - ts) / k).sum(axis=1))
        u = (tt[0] - tt) / (tt[0] - t_star)
        runs[label] = {
            "EA_N": ea,
            "x_mm": x_mm,
            "u": u,
            "T0_star_N": float(t_star),
            "x50_mm": first_crossing(x_mm, u, 0.5),
            "x90_mm": first_crossing(x_mm, u, 0.9),
            "x100_mm": first_crossing(x_mm, u, 1.0 - 1e-9),
        }
    return {
        "alpha_rad": alpha,
        "phi": phi,
        "sum_phi": float(phi.sum()),
        "band_end_N": float(200.0 * np.exp(-2 * phi.sum())),
        "l0_m": l_0,
        "l_seg_m": l_seg,
        "runs": runs,
    }


def figure(b, s, out: Path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(10.0, 4.6), dpi=110)
    # (a) bench
    for travel, u, d in b["curves"]:
        ax1.plot(travel, u, lw=0.35, alpha=0.18, color="tab:blue" if d > 0 else "tab:orange")
    ax1.plot(GRID, b["median"], color="k", lw=2.0, label="median of reversals")
    ax1.axvline(0.0, color="0.4", ls="--", lw=1.2, label="rigid play operator")
    bs = b["summary"]["input_torque"]
    for lv, key in zip(LEVELS, ("50%", "90%")):
        m, (lo, hi) = bs[key]["median_deg"], bs[key]["p10_p90_deg"]
        ax1.axhline(lv, color="0.75", lw=0.7, zorder=0)
        ax1.errorbar(m, lv, xerr=[[m - lo], [hi - m]], fmt="o", color="crimson", ms=4, capsize=3, lw=1.2, zorder=5)
        ax1.annotate(
            f"{key}: {m:.2f}° (p10–p90 of reversals: {lo:.2f}–{hi:.2f}°)",
            (hi, lv),
            xytext=(6, -12 if lv > 0.6 else 4),
            textcoords="offset points",
            fontsize=8,
            color="crimson",
        )
    ax1.plot([], [], color="tab:blue", lw=1, label="reversal, angle rising after")
    ax1.plot([], [], color="tab:orange", lw=1, label="reversal, angle falling after")
    ax1.set_xlim(-0.3, 8.0)
    ax1.set_ylim(-0.05, 1.12)
    ax1.set_xlabel("spindle angle travelled since the reversal [deg]")
    ax1.set_ylabel("fraction of the friction band crossed, u [-]")
    ax1.set_title(f"(a) Bench: da Vinci instrument, {b['summary']['reversals']} reversals", fontsize=10)
    ax1.legend(loc="lower right", fontsize=7.5, framealpha=0.9)
    # (b) simulator
    colors = {"10x stiffer": "tab:green", "recipe": "tab:red", "10x softer": "tab:purple"}
    ins = ax2.inset_axes([0.53, 0.27, 0.44, 0.26])
    for label, r in s["runs"].items():
        mant, expo = f"{r['EA_N']:.1e}".split("e")
        name = f"EA = {mant}×10$^{{{int(expo)}}}$ N" + (" (recipe)" if label == "recipe" else f" ({label})")
        for ax in (ax2, ins):
            ax.plot(
                r["x_mm"],
                np.minimum(r["u"], 1.0),
                color=colors[label],
                lw=1.8,
                label=f"{name}: 50 / 90 % at {r['x50_mm']:.3g} / {r['x90_mm']:.3g} mm",
            )
            ax.plot([r["x50_mm"], r["x90_mm"]], LEVELS, "o", color=colors[label], ms=4)
    for ax in (ax2, ins):
        ax.axvline(0.0, color="0.4", ls="--", lw=1.2, label="rigid tendon (play operator): x = 0")
        for lv in LEVELS:
            ax.axhline(lv, color="0.75", lw=0.7, zorder=0)
    soft = s["runs"]["10x softer"]
    ax2.set_xlim(-0.03 * soft["x100_mm"], 1.05 * soft["x100_mm"])
    ax2.set_ylim(-0.05, 1.12)
    rec = s["runs"]["recipe"]
    ins.set_xlim(-0.1, 1.1 * rec["x100_mm"])
    ins.set_ylim(-0.05, 1.08)
    ins.tick_params(labelsize=7)
    ins.set_title("zoom: 0–3 mm", fontsize=7.5, pad=2)
    ins.grid(alpha=0.25)
    ax2.set_xlabel("actuator displacement since the reversal (tendon paid out) [mm]")
    ax2.set_ylabel("fraction of the band of actuator tension crossed, u [-]")
    ax2.set_title("(b) Simulator: snake12-elastic, one tendon through 11 guides", fontsize=10)
    ax2.legend(loc="lower right", fontsize=7, framealpha=0.95)
    ax2.text(
        0.13,
        0.97,
        f"every joint at 5°: φ = {s['phi'][0]:.4f} per guide, Σφ = {s['sum_phi']:.3f}\n"
        f"T$_0$: 80 → 200 → 80 N; band at 200 N: 200 → {s['band_end_N']:.1f} N\n"
        f"l$_0$ = {s['l0_m']} m (actuator → guide 1), l$_s$ = {s['l_seg_m'] * 1e3:.0f} mm",
        transform=ax2.transAxes,
        va="top",
        fontsize=7.5,
        color="0.25",
    )
    for ax in (ax1, ax2):
        ax.grid(alpha=0.25)
        ax.tick_params(labelsize=8)
        ax.xaxis.label.set_size(9)
        ax.yaxis.label.set_size(9)
    fig.suptitle(
        "A reversal: the edge of the friction band against actuator displacement, beside the bench's", fontsize=11
    )
    fig.text(0.01, 0.01, CITATION, fontsize=6.5, color="0.35")
    fig.tight_layout(rect=(0, 0.03, 1, 0.97))
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=110)
    plt.close(fig)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--bench", type=Path, default=BENCH, help="the mis-tool-characterization folder")
    ap.add_argument("--out", type=Path, default=ROOT / "docs" / "_static" / "elastic_edge.png")
    ap.add_argument("--json", type=Path, default=ROOT / "docs" / "_static" / "elastic_edge.json")
    args = ap.parse_args(argv)
    folder = args.bench / FOLDER
    if not folder.is_dir() or not any(folder.glob("*.TXT")):
        print(f"elastic_edge: bench data not found at {folder}; skipping (nothing written).")
        return 0
    t_start = time.perf_counter()
    b = bench(folder)
    s = simulator()
    figure(b, s, args.out)
    bs = b["summary"]
    print(f"bench: {bs['files']} files, {bs['reversals']} reversals (input torque)")
    for key in ("50%", "90%"):
        q = bs["input_torque"][key]
        print(
            f"  {key} of the band at {q['median_deg']:.2f} deg (median; range {q['range_deg'][0]:.2f}-"
            f"{q['range_deg'][1]:.2f}, 10-90 % {q['p10_p90_deg'][0]:.2f}-{q['p10_p90_deg'][1]:.2f})"
        )
    for key, q in bs["by_direction"].items():
        print(f"  {key}: 50 % {q['50%']['median_deg']:.2f} deg, 90 % {q['90%']['median_deg']:.2f} deg")
    q = bs["check_input_minus_output"]
    print(
        f"  check, input - output torque: 50 % {q['50%']['median_deg']:.2f} deg, 90 % {q['90%']['median_deg']:.2f} deg"
    )
    for k, q in bs["fit_window_sensitivity"].items():
        print(f"  fit window {k} deg: 50 % {q['50%']['median_deg']:.2f} deg, 90 % {q['90%']['median_deg']:.2f} deg")
    print(
        f"simulator: phi per guide {np.round(s['phi'], 4).tolist()}, sum {s['sum_phi']:.4f}, "
        f"band 200 -> {s['band_end_N']:.2f} N"
    )
    for label, r in s["runs"].items():
        print(
            f"  EA {r['EA_N']:.3g} N ({label}): joint side moves at T0 = {r['T0_star_N']:.2f} N; "
            f"x50 {r['x50_mm']:.3f} mm, x90 {r['x90_mm']:.3f} mm, x100 {r['x100_mm']:.3f} mm"
        )
    runtime = time.perf_counter() - t_start
    print(f"wrote {args.out} ({runtime:.1f} s)")
    if args.json:
        doc = {
            "bench": bs,
            "simulator": {
                "recipe": "snake12-elastic",
                "pose": "every joint 5 deg about its first axis",
                "tendon": "set 12, tendon 1",
                "alpha_rad": s["alpha_rad"].tolist(),
                "phi": s["phi"].tolist(),
                "sum_phi": s["sum_phi"],
                "band_end_N": s["band_end_N"],
                "l0_m": s["l0_m"],
                "l_seg_m": s["l_seg_m"],
                "runs": {k: {kk: v for kk, v in r.items() if kk not in ("x_mm", "u")} for k, r in s["runs"].items()},
            },
            "runtime_s": runtime,
            "citation": CITATION,
        }
        args.json.parent.mkdir(parents=True, exist_ok=True)
        args.json.write_text(json.dumps(doc, indent=2) + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main())
