"""Recordings handed over to a physics model's fit are freed once their arrays are read (issue 42's scale).

A snake's hour of logging is 1.7 GiB: kept beside its arrays for the whole calibration, the
recording alone was a third of the fit's peak. The CLI hands its list over
(:func:`tendon_id.cli.common.handed_over`); a caller that keeps its recordings keeps them, with
the same fit.
"""

from __future__ import annotations

import gc
import weakref

import numpy as np
import pytest
from passage_data import tendon_passage

from tendon_id import zoo
from tendon_id.cli.common import handed_over
from tendon_id.datasets import load_recipe
from tendon_id.sim import simulate
from tendon_id.zoo.passage import PassageCapstan


def test_handed_over_empties_the_callers_list():
    items = [object(), object()]
    first = items[0]
    out = handed_over(items)
    assert items == [] and out[0] is first and len(out) == 2


def snake_recordings():
    recipe = load_recipe("snake12-noise-only")
    return [
        simulate(recipe, "planned-paths", effects="contact,stick_slip", frames=300, seed=s).recording for s in (1, 2)
    ]


def passage_recordings():
    return [tendon_passage(s, n=300) for s in range(2)]


@pytest.mark.parametrize(
    "make, model, calibrate",
    [
        (
            snake_recordings,
            lambda: zoo.make("capstan-nonsmooth", n_starts=1, maxeval=30),
            "tendon_id.zoo.capstan.calibrate_capstan",
        ),
        (
            passage_recordings,
            lambda: PassageCapstan(blocks=["stick_slip"]),
            "tendon_id.zoo.passage.model.calibrate_passage",
        ),
    ],
    ids=["capstan", "passage"],
)
def test_a_fit_frees_recordings_handed_over(monkeypatch, make, model, calibrate):
    import importlib

    module_name, name = calibrate.rsplit(".", 1)
    module = importlib.import_module(module_name)
    real, alive = getattr(module, name), []
    made: list = []

    def watched(*args, **kwargs):
        gc.collect()
        alive.append(sum(r() is not None for r in made))
        return real(*args, **kwargs)

    monkeypatch.setattr(module, name, watched)

    def recordings():
        recs = make()
        made.extend(weakref.ref(r.frame) for r in recs)  # a recording has no weak references; its data does
        return recs

    handed = model().fit(recordings())
    assert alive == [0]  # none left when the calibration starts
    kept = recordings()
    same = model().fit(kept)
    assert alive[1] == 2 and all(r.n_frames == 300 for r in kept)  # a caller's own stay
    for key in ("A_", "B_", "theta_"):
        if hasattr(handed, key):
            got, want = getattr(handed, key), getattr(same, key)
            assert np.array_equal(got, want) if isinstance(got, np.ndarray) else got == want, key


def test_the_joint_fit_lets_go_of_the_problems_design(monkeypatch):
    """A nonsmooth fit with free block parameters reads the forward model: the design built for its smooth
    start (a third of a snake's recording) is freed before the joint fit, which gives the same law."""
    from tendon_id.calibration import law

    designs, alive = [], []
    real_fits, real_joint = law.law_fits, law._fit_joint

    def fits_watched(problem):
        if problem.guide_design is not None:
            designs.append(weakref.ref(problem.guide_design))
        return real_fits(problem)

    def joint_watched(problem, rng):
        gc.collect()
        alive.append((problem.guide_design is None, designs[0]() is None, problem.n_guides))
        return real_joint(problem, rng)

    monkeypatch.setattr(law, "law_fits", fits_watched)
    monkeypatch.setattr(law, "_fit_joint", joint_watched)
    (rec,) = snake_recordings()[:1]
    model = zoo.make("capstan-nonsmooth", n_starts=1, maxeval=30).fit(rec)
    assert alive == [(True, True, rec.n_modules - 1)]
    assert np.all(np.isfinite(model.A_)) and np.all(model.B_ >= np.abs(model.A_))
