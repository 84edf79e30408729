"""The regime map: when does a learned cascade beat calibrated physics, and by how much?

``tendon-id benchmark regimes`` varies the truth of a recipe one physical setting at a time
and, in each regime, compares the learned cascades with calibrated ``capstan-nonsmooth`` on
held-out trajectories:

=====================  ==========================================================  ===============
setting                values                                                      recipe default
=====================  ==========================================================  ===============
stick/slip driver      ``tension`` (a change of entering tension), ``motion``       the recipe's
                       (also the tendon drawn through a guide by the joints beyond),
                       ``elastic`` (both, from an elastic tendon)
tendon stiffness EA    the recipe's times 0.1 and 10 (elastic driver only)         3.5e4 N
viscoelastic kappa     0, half, the recipe's, double (where the recipe has the lag)  0.12
per-tendon wraps       on (exact wraps of each tendon), off (the backbone's)        on
friction level         the recipe's ``(A_i, B_i)`` times 0.5, 1, 2                  1
session                ``continuous`` (each log starts in the state the unlogged    continuous
                       motion left), ``fresh`` (each starts from forward slip)
=====================  ==========================================================  ===============

The grid is the recipe itself and every other value of one setting at a time, each in both
sessions (18 regimes for ``snake12-paper``, 16 for ``snake12-elastic``, whose truth has no lag).
A regime's data are the paper's Section IV-B split (:func:`~tendon_id.benchmarks.splits.paper_split`:
the same held-out 800 / 500 / 1260 test frames), with a smaller training pool of
:data:`TRAIN_FRAMES` frames so that the whole map trains on 2 cores in under 20 minutes with the ``fast`` preset.

Each regime reports the terminal and intermediate-joint RMSE of ``capstan-nonsmooth``,
``pg-chtc`` and ``pg-chtc-ns``, overall (frame-weighted over the three test protocols), their
ratios to ``capstan-nonsmooth``, and the measured floor where one exists: with a fresh start
the exact physics knows every state, so what is left is the load cells' noise, measured as
the RMSE of the noisy terminal labels against the simulator's noise-free truth.  (With a
continuous session the floor is the start state's, which ``experiments/start_state_floor.py``
measures for a whole recipe.)

Regimes are independent jobs run through :class:`joblib.Parallel` (so on Dask or Ray unchanged),
each the top-level :func:`regime_job`, with plain values in and out.
"""

from __future__ import annotations

import os
import time
from collections.abc import Sequence
from dataclasses import asdict, dataclass, replace

import numpy as np
from joblib import delayed

from tendon_id.benchmarks.jobs import job_runner
from tendon_id.benchmarks.splits import TEST_PROTOCOLS, paper_split, score_test
from tendon_id.datasets import load_recipe
from tendon_id.errors import ConfigError
from tendon_id.metrics import frame_weighted, tendon_metrics
from tendon_id.progress import progress_bar
from tendon_id.sim import Recipe, simulate
from tendon_id.sim.effects import Effects
from tendon_id.sim.protocols import ProtocolSettings
from tendon_id.sim.transmission import FrictionLaw
from tendon_id.zoo import make
from tendon_id.zoo.guard import quiet_guard

#: The models of the map: the physics baseline first (the ratios' denominator).
METHODS = ("capstan-nonsmooth", "pg-chtc", "pg-chtc-ns")
#: Training pool of a regime [frames] (the paper's is 23 000).
TRAIN_FRAMES = 6000
#: Frames simulated per protocol in a regime: enough for the pool and the paper's test trajectories.
REGIME_FRAMES = {"terminal-only": 5000, "posterior-3": 2000, "posterior-6": 1000, "planned-paths": 1260}
#: The settings each regime varies, and their values (kappa and friction as multiples of the recipe's).
GRID = {
    "driver": ("tension", "motion", "elastic"),
    "ea_scale": (0.1, 1.0, 10.0),
    "kappa_scale": (0.0, 0.5, 1.0, 2.0),
    "wraps": (True, False),
    "friction_scale": (0.5, 1.0, 2.0),
}
SESSIONS = ("continuous", "fresh")


@dataclass(frozen=True)
class Regime:
    """One physical regime: the recipe with one setting changed (see the module docstring).

    Attributes
    ----------
    driver : {"tension", "motion", "elastic"}, optional
        What makes a guide slip (``stick_slip.driver``); None: the recipe's.
    ea_scale : float
        The tendon's axial stiffness ``EA`` as a multiple of the recipe's [-] (elastic driver).
    kappa_scale : float
        Viscoelastic relaxing fraction as a multiple of the recipe's ``kappa`` [-].
    wraps : bool
        Exact per-tendon wraps (``per_tendon_wrap`` on).
    friction_scale : float
        The truth's ``(A_i, B_i)`` times this [-].
    session : {"continuous", "fresh"}
    """

    driver: str | None = None
    ea_scale: float = 1.0
    kappa_scale: float = 1.0
    wraps: bool = True
    friction_scale: float = 1.0
    session: str = "continuous"

    @property
    def setting(self) -> str:
        """The setting that differs from the recipe, in words ("recipe" if none)."""
        base = Regime(session=self.session)
        changed = [k for k in GRID if getattr(self, k) != getattr(base, k)]
        if not changed:
            return "recipe"
        k = changed[0]
        v = getattr(self, k)
        if k == "driver":
            return f"driver {v}"
        if k == "ea_scale":
            return f"EA x{v:g}"
        if k == "wraps":
            return "wraps " + ("on" if v else "off")
        return f"{'kappa' if k == 'kappa_scale' else 'mu'} x{v:g}"

    def recipe(self, base: Recipe) -> Recipe:
        """``base`` with this regime's truth, and :data:`REGIME_FRAMES` per protocol."""
        eff = base.effects
        enabled = [e for e in eff.enabled if e != "per_tendon_wrap" or self.wraps]
        if self.wraps and "per_tendon_wrap" not in enabled:
            enabled.append("per_tendon_wrap")
        if self.driver is not None and "stick_slip" not in enabled:
            raise ConfigError(f"recipe {base.name!r} has no stick_slip effect whose driver could change")
        params = {name: asdict(p) for name, p in eff.params.items()}
        if self.driver is not None:
            params["stick_slip"]["driver"] = self.driver
        params["stick_slip"]["EA"] = float(params["stick_slip"]["EA"]) * self.ea_scale
        params["viscoelastic"]["kappa"] = float(params["viscoelastic"]["kappa"]) * self.kappa_scale
        friction = FrictionLaw(
            A=tuple(a * self.friction_scale for a in base.friction.A),
            B=tuple(b * self.friction_scale for b in base.friction.B),
        )
        protocols = {
            p: replace(base.protocol(p), frames=n) if p in base.protocols else ProtocolSettings(frames=n)
            for p, n in REGIME_FRAMES.items()
        }
        return replace(
            base,
            name=f"{base.name} [{self.setting}, {self.session}]",
            session=self.session,
            effects=Effects(enabled=tuple(enabled), params=params),
            friction=friction,
            protocols={**dict(base.protocols), **protocols},
        )


def grid_regimes(base: str | Recipe = "snake12-paper") -> list[Regime]:
    """The recipe, then each other value of one setting at a time; each in both sessions.

    Settings that do not act in ``base`` are left out: the stiffness without the elastic
    driver, the lag's fraction where the recipe has no lag, and the recipe's own driver.
    """
    r = load_recipe(base) if isinstance(base, str) else base
    ss = r.effects.get("stick_slip")
    axes = dict(GRID)
    axes["driver"] = tuple(d for d in GRID["driver"] if d != ss.driver)
    if ss.driver != "elastic":
        axes.pop("ea_scale")
    if "viscoelastic" not in r.effects:
        axes.pop("kappa_scale")
    settings = [Regime()]
    for k, values in axes.items():
        settings += [Regime(**{k: v}) for v in values if v != getattr(Regime(), k)]
    return [replace(reg, session=s) for reg in settings for s in SESSIONS]


def nonsmooth_truth_recipe(base: str | Recipe = "snake12-paper") -> Recipe:
    """``base`` whose truth is capstan-nonsmooth itself: contact and stick/slip only, each log from forward slip."""
    r = load_recipe(base)
    return replace(
        r,
        name=f"{r.name} [nonsmooth truth, fresh]",
        session="fresh",
        effects=r.effects.with_enabled(("contact", "stick_slip")),
    )


def _noise_floor(recipe: Recipe, seed: int, test: dict) -> dict:
    """Terminal RMSE of the noisy labels against the noise-free truth on the test trajectories, frame-weighted."""
    ms, frames = [], []
    for p in TEST_PROTOCOLS:
        sim = simulate(recipe, p, seed=recipe.seed)
        n = sim.recording.n_modules
        keep = np.isin(sim.recording.trajectory_ids, test[p].trajectories)
        ms.append(tendon_metrics(sim.chain[keep, n - 1, n - 1], sim.recording.terminal[keep]))
        frames.append(int(keep.sum()))
    return frame_weighted(ms, frames)


def regime_job(base: str, regime: dict, seed: int, preset: str, threads: int | None = None) -> dict:
    """Fit and score the three models in one regime; picklable, plain values in and out.

    Returns
    -------
    dict
        ``{"regime": dict, "setting": str, "methods": {name: {"terminal": M, "joints": M | None}},
        "floor": M | None, "frames": {...}, "seconds": float}``.
    """
    import torch

    if threads:
        torch.set_num_threads(int(threads))
    t0 = time.perf_counter()
    r = Regime(**regime)
    recipe = r.recipe(load_recipe(base))
    split = paper_split(recipe, seed, train_frames=TRAIN_FRAMES, progress=False)
    methods = {}
    for name in METHODS:
        model = make(name, **({"preset": preset, "seed": seed, "progress": False} if name != METHODS[0] else {}))
        with quiet_guard():  # its figures are in the result and on the page
            model.fit(split.calibration)
        scored = score_test(model, split.test)
        methods[name] = {
            "terminal": scored["terminal"],
            "joints": scored["joints"],
            "guard": getattr(model, "guard_", None),
        }
    return {
        "regime": regime,
        "setting": r.setting,
        "session": r.session,
        "methods": methods,
        "floor": _noise_floor(recipe, seed, split.test) if r.session == "fresh" else None,
        "frames": {
            "train": split.train.n_frames,
            "val": split.val.n_frames,
            **{p: split.test[p].n_frames for p in TEST_PROTOCOLS},
        },
        "seconds": time.perf_counter() - t0,
    }


def regimes(
    *,
    recipe: str = "snake12-paper",
    preset: str = "fast",
    seed: int = 0,
    backend: str | None = "loky",
    n_jobs: int = 1,
    progress: bool | None = None,
    only: Sequence[Regime] | None = None,
) -> dict:
    """The regime map (see the module docstring).

    Parameters
    ----------
    recipe : str
        The recipe whose truth is varied.
    preset : str
        Size and schedule of the learned models.
    seed : int
        Seed of every split and model.
    backend : str or None
        joblib backend (``"loky"``, ``"threading"``, a registered ``"dask"``...).
    n_jobs : int
        Parallel regimes (joblib's meaning); each job's torch then uses ``cores / n_jobs`` threads.
    progress : bool, optional
        Progress bar over finished regimes.
    only : sequence of Regime, optional
        Run these regimes instead of the whole grid (:func:`grid_regimes`).

    Returns
    -------
    dict
        ``{"benchmark": "regimes", "preset", "recipe", "rows": [...], "cells": [...], "seconds"}``:
        ``rows`` in the :doc:`/cli` shape (one per method and regime, ``protocol`` "overall", plus
        ``"regime"``, ``"ratio_terminal"`` and ``"ratio_joints"`` to capstan-nonsmooth), ``cells``
        :func:`regime_job`'s results.
    """
    t0 = time.perf_counter()
    parallel = job_runner(backend, n_jobs)
    load_recipe(recipe)  # an unknown recipe fails before any job starts
    cells = list(only) if only is not None else grid_regimes(recipe)
    threads = None
    if n_jobs != 1:  # share the cores: each job's torch gets its part
        cores = os.cpu_count() or 1
        threads = max(1, cores // (int(n_jobs) if n_jobs > 0 else cores))
    out = parallel(delayed(regime_job)(recipe, asdict(c), seed, preset, threads) for c in cells)
    results = list(progress_bar(out, desc="regimes", total=len(cells), enable=progress))
    rows = []
    for res in results:
        base = res["methods"][METHODS[0]]
        for name, m in res["methods"].items():
            rows.append(
                {
                    "method": name,
                    "protocol": "overall",
                    "regime": f"{res['setting']}, {res['session']}",
                    "terminal": m["terminal"],
                    "joints": m["joints"],
                    "ratio_terminal": m["terminal"]["rmse"] / base["terminal"]["rmse"],
                    "ratio_joints": m["joints"]["rmse"] / base["joints"]["rmse"],
                    "floor_rmse": res["floor"]["rmse"] if res["floor"] else None,
                }
            )
    return {
        "benchmark": "regimes",
        "preset": preset,
        "recipe": recipe,
        "seed": seed,
        "rows": rows,
        "cells": results,
        "seconds": time.perf_counter() - t0,
    }


def format_regimes(result: dict) -> str:
    """The map as text: per regime, each model's overall RMSE and its ratio to capstan-nonsmooth."""
    head = (
        f"{'regime':34s} {'method':18s} {'terminal [N]':>12s} {'ratio':>6s} {'joints [N]':>10s} {'ratio':>6s} "
        f"{'floor':>6s}"
    )
    lines = [
        f"regimes ({result['recipe']}, preset {result['preset']}, seed {result['seed']}, {result['seconds']:.0f} s)",
        head,
        "-" * len(head),
    ]
    for r in result["rows"]:
        floor = f"{r['floor_rmse']:6.2f}" if r["floor_rmse"] is not None else f"{'-':>6s}"
        lines.append(
            f"{r['regime']:34s} {r['method']:18s} {r['terminal']['rmse']:12.2f} {r['ratio_terminal']:6.2f} "
            f"{r['joints']['rmse']:10.2f} {r['ratio_joints']:6.2f} {floor}"
        )
    return "\n".join(lines)
