"""The diagnosis of a bench passage: splits by file, the passage blocks as candidates, the CLI with --mapping."""

from __future__ import annotations

import json

import numpy as np
import pytest
from passage_data import tendon_passage

from tendon_id import zoo
from tendon_id.cli import main
from tendon_id.diagnosis import DiagnosisSettings, diagnose
from tendon_id.errors import ConfigError
from tendon_id.family.inputs import Stacked
from tendon_id.zoo.passage import PassageCapstan, PassageInputs
from tendon_id.zoo.passage.diagnosis import file_splits, passage_strata

SETTINGS = DiagnosisSettings(n_boot=200, block_s=2.0)


def test_a_passage_with_stick_slip_is_diagnosed_as_stick_slip():
    train, test = [tendon_passage(s, n=900) for s in (0, 1)], [tendon_passage(s, n=900) for s in (2, 3)]
    res = diagnose(zoo.make("passage-capstan", warmup_s=0.5), train, test, settings=SETTINGS, progress=False)
    top = res.candidates[0]
    assert top.effect == "stick_slip" and top.significant
    assert res.ladder[1].effects == ["base", "stick_slip"] and res.ladder[1].heldout_rmse < 0.55 * res.base_rmse
    velocity = next(c for c in res.candidates if c.effect == "velocity_friction")
    assert velocity.heldout_rmse > top.heldout_rmse
    assert res.verdict.kind in ("explained", "partial") and res.verdict.effects[0] == "stick_slip"
    assert res.skipped["smooth_edge"].startswith("refines stick_slip")
    assert res.unit == "N" and "N m" not in res.summary()
    js = res.to_dict()
    assert js["unit"] == "N" and js["ladder"][0]["effects"] == ["base"]
    kinds = {s.kind for s in res.where}
    assert {"reversal", "load", "speed", "position", "start"} <= kinds


def test_splits_are_by_file_and_strata_cover_every_frame():
    recs = [tendon_passage(s, n=300) for s in range(4)]
    splits, how = file_splits(recs, None, folds=2)
    assert "by file" in how and len(splits) == 2
    whole = [r.input for r in recs]
    for s in splits:
        # no file on both sides: each side is whole files, and together they are every file once
        test = [k for k, x in enumerate(whole) if np.isin(x, s.test.input).all()]
        train = [k for k, x in enumerate(whole) if np.isin(x, s.train.input).all()]
        assert test and train and sorted(test + train) == list(range(len(recs)))
        assert s.test.n_frames == sum(whole[k].size for k in test)
    with pytest.raises(ConfigError, match="two or more files"):
        file_splits(recs[:1], None, folds=3)


@pytest.mark.parametrize("folds", [2, 3, 5])
def test_file_splits_are_the_files_inputs_as_parts_of_one_stack(folds):
    """Each side equals the inputs of its files read alone; a fold's sides are views of one stack, and the
    held-out folds stacked back are that stack itself (issue 42: no copy per fold). A training set on both
    sides of its held-out files is kept as its two parts, stacked only when read."""
    recs = [tendon_passage(s, n=200 + 50 * s) for s in range(5)]
    splits, _ = file_splits(recs, None, folds=folds)
    groups = np.array_split(np.arange(len(recs)), folds)
    stack = splits[0].test.input.base
    for g, s in zip(groups, splits):
        for side, files in ((s.test, list(g)), (s.training(), [i for i in range(len(recs)) if i not in g])):
            alone = PassageInputs.from_recordings([recs[i] for i in files])
            for f in PassageInputs.frame_fields:
                np.testing.assert_array_equal(getattr(side, f), getattr(alone, f), err_msg=f)
            np.testing.assert_array_equal(side.direction(0.01), alone.direction(0.01))
        assert np.shares_memory(s.test.input, stack)
        at_an_end = g[0] == 0 or g[-1] == len(recs) - 1
        assert isinstance(s.train, Stacked) != at_an_end  # parts between the ends, stacked when read
        train = s.training()
        assert train.n_frames == s.train.n_frames
        assert np.shares_memory(train.input, stack) == at_an_end  # a copy only between the ends
        assert at_an_end or s.training().input is not train.input  # made for each reader, kept by none
    heldout = PassageInputs.concat([s.test for s in splits])
    assert heldout.input.base is stack and heldout.n_frames == sum(r.n_frames for r in recs)
    with pytest.raises(ValueError, match="does not start a trajectory"):
        splits[0].test.part(1, 10)
    inputs = PassageInputs.from_recordings(recs)
    strata = dict((name, mask) for name, _, mask in passage_strata(inputs))
    near, away = strata["near reversals"], strata["away from reversals"]
    assert near.any() and away.any() and np.array_equal(near, ~away)


def test_a_log_starts_on_the_edge_of_its_first_motion():
    rec = tendon_passage(0, n=400)
    inputs = PassageInputs.from_recordings(rec)
    model = PassageCapstan(blocks=("stick_slip",))
    first = inputs.first_motion(1e-9)
    sigma = inputs.slip_state(1e-9)
    assert first[0] == sigma[np.flatnonzero(sigma)[0]]
    # The opposite motion: the log starts on the other edge.
    back = PassageInputs.from_recordings(
        type(rec)(rec.frame.assign(position=-rec.frame["position"], input=rec.frame["input"][::-1].values), rec.meta)
    )
    assert back.first_motion(1e-9)[0] == -first[0]
    forward, reverse = model.edges(back, {"gain": 1.0, "phi": 0.3, "offset": 0.0})
    y = model.reading(back, {"gain": 1.0, "phi": 0.3, "offset": 0.0})
    assert y[0] == (forward[0] if back.first_motion(1e-9)[0] > 0 else reverse[0])


def test_the_cli_diagnoses_bench_files_and_refuses_a_snake_effect(tmp_path, capsys):
    paths = []
    for s in range(4):
        paths.append(tmp_path / f"run{s}.parquet")
        tendon_passage(s, n=600).write(paths[-1])
    args = ["diagnose", "--base", "passage-capstan", "--data", str(paths[0]), "--data", str(paths[1])]
    args += ["--test", str(paths[2]), "--test", str(paths[3])]
    code = main([*args, "--out", str(tmp_path / "d.html"), "--json", str(tmp_path / "d.json")])
    out = capsys.readouterr()
    assert code == 0, out.err
    js = json.loads((tmp_path / "d.json").read_text())
    assert js["unit"] == "N" and js["candidates"][0]["effect"] == "stick_slip"
    assert "held-out files (2 for fitting, 2 held out)" in js["validation"]
    code = main([*args, "--candidates", "bending_stiffness", "--out", str(tmp_path / "e.html")])
    err = capsys.readouterr().err
    assert code == 2 and "unknown candidate" in err and "stick_slip" in err


def test_the_diagnosis_lets_go_of_recordings_passed_on_and_splits_forget_derived_arrays(monkeypatch):
    """Recordings the caller passed on (as the CLI does) are freed before the base is fitted and refitted,
    on the stacked signals; each refit leaves its split without derived arrays (issue 42: memory at scale)."""
    import gc
    import weakref

    from tendon_id.diagnosis import runner

    made, seen = [], []

    def recordings():
        recs = [tendon_passage(s, n=300) for s in range(3)]
        made.extend(weakref.ref(r.frame) for r in recs)  # a recording has no weak references; its data does
        return recs

    real = runner.refit_and_score

    def watched(family, structure, split, *rest):
        gc.collect()
        seen.append(sum(r() is not None for r in made))
        out = real(family, structure, split, *rest)
        assert not split.test.cache and (isinstance(split.train, Stacked) or not split.train.cache)
        return out

    monkeypatch.setattr(runner, "refit_and_score", watched)
    fit = PassageCapstan.fit

    def fit_watched(self, data):
        seen.append(("base fit", isinstance(data, PassageInputs), sum(r() is not None for r in made)))
        return fit(self, data)

    monkeypatch.setattr(PassageCapstan, "fit", fit_watched)
    settings = DiagnosisSettings(n_boot=50, block_s=0.5, null_draws=0)
    res = diagnose(PassageCapstan(warmup_s=0.2), recordings(), None, ["stick_slip"], settings=settings, progress=False)
    # The unfitted base is fitted on the stacked signals too, once the recordings are gone.
    assert res.validation.startswith("3-fold") and seen[0] == ("base fit", True, 0)
    assert len(seen) > 1 and seen[1:] == [0] * (len(seen) - 1)
    seen.clear()
    kept = recordings()  # a caller that keeps its recordings keeps them, and gets the same result
    again = diagnose(PassageCapstan(warmup_s=0.2), kept, None, ["stick_slip"], settings=settings, progress=False)
    assert again.base_rmse == res.base_rmse and all(r.n_frames == 300 for r in kept)
    # The stacked signals are the recordings' arrays: the base fits to the same bits either way.
    splits, _ = file_splits(kept, None, folds=3)
    on_stack = PassageCapstan(warmup_s=0.2).fit(PassageInputs.concat([s.test for s in splits]))
    assert on_stack.theta_ == PassageCapstan(warmup_s=0.2).fit(kept).theta_
