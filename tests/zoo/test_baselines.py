"""Learning-only baselines (paper Table I): shapes, contract, persistence, no intermediate truth, sizes."""

import json

import numpy as np
import pytest
import torch

from learners.baselines import KINDS, baseline_config, build_baseline, count_parameters
from tendon_id import zoo
from tendon_id.data import Recording
from tendon_id.datasets import load_recipe
from tendon_id.errors import ConfigError
from tendon_id.sim import simulate
from tendon_id.zoo.snake.contract import scrambled_truth


@pytest.fixture(scope="module")
def single():
    # 1200 frames: two 600-frame trajectories, one to train on and one for early stopping.
    return simulate(load_recipe("snake12-paper"), "single-passage", frames=1200, seed=0).recording


@pytest.fixture(scope="module")
def snake():
    return simulate(load_recipe("snake12-paper"), "posterior-3", frames=600, seed=0).recording


@pytest.fixture(scope="module")
def fitted(single, snake):
    """Every baseline fitted once (tiny preset) on each rig."""
    return {
        (k, n): zoo.make(k, preset="tiny", device="cpu").fit(rec)
        for k in KINDS
        for n, rec in ((2, single), (12, snake))
    }


def test_registered_in_the_zoo():
    assert {"mlp", "lstm", "transformer"} <= set(zoo.names())
    m = zoo.make("lstm", preset="tiny", seed=3)
    assert m.get_params()["seed"] == 3 and m.get_params()["mode"] == "auto"
    with pytest.raises(ConfigError, match="no setting"):
        zoo.make("mlp", hidden=3)


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("n", [2, 12])
def test_shapes_and_contract(fitted, single, snake, kind, n):
    rec = single if n == 2 else snake
    m = fitted[(kind, n)]
    assert m.mode_ == ("unit" if n == 2 else "end-to-end")
    assert m.net_.cfg.n_inputs == (8 if n == 2 else 5 * n)
    pred, chain = m.predict(rec), m.predict_chain(rec)
    assert pred.shape == (rec.n_frames, n, 3) and chain.shape == (rec.n_frames, n, n, 3)
    np.testing.assert_array_equal(chain[:, np.arange(n), np.arange(n)], pred)
    assert np.all(np.isnan(chain[:, np.arange(n)[:, None] > np.arange(n)[None, :]]))
    assert np.all(np.isfinite(pred)) and np.all(pred > 0)
    # No estimate for joints 1..N-1: their actuator side (proximal); only T[N, N] is learned.
    np.testing.assert_array_equal(pred[:, :-1], rec.actuator[:, :-1])
    assert not np.array_equal(pred[:, -1], rec.actuator[:, -1])
    s = m.score(rec)
    assert set(s["terminal"]) == {"rmse", "r2", "max_error"} and len(s["joints"]["per_joint"]) == n
    assert len(m.history_["epochs"]) >= 1


@pytest.mark.parametrize("kind", KINDS)
def test_predictions_are_causal(fitted, snake, kind):
    m = fitted[(kind, 12)]
    first = snake.select([snake.trajectories[0]])
    cut = Recording(first.frame.iloc[:120].reset_index(drop=True), first.meta)
    # A prefix of a trajectory gets the same estimates as the whole (no look-ahead), and a
    # trajectory on its own the same as in a batch of trajectories.
    np.testing.assert_allclose(m.predict_terminal(cut), m.predict_terminal(snake)[:120], rtol=1e-5)


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("n", [2, 12])
def test_save_load_predicts_identically_without_pickle(fitted, single, snake, tmp_path, kind, n):
    rec = single if n == 2 else snake
    m = fitted[(kind, n)]
    folder = m.save(tmp_path / kind)
    assert sorted(p.name for p in folder.iterdir()) == ["arrays.npz", "model.json"]
    doc = json.loads((folder / "model.json").read_text(), parse_constant=lambda c: pytest.fail(f"non-JSON {c}"))
    assert doc["model"] == kind and doc["state"]["mode"] == m.mode_
    with np.load(folder / "arrays.npz", allow_pickle=False) as npz:
        assert all(npz[k].dtype != object for k in npz.files)
    back = zoo.load(folder)
    assert type(back) is type(m) and back.get_params() == m.get_params()
    np.testing.assert_array_equal(back.predict(rec), m.predict(rec))
    np.testing.assert_array_equal(back.predict_chain(rec), m.predict_chain(rec))


@pytest.mark.parametrize("kind", KINDS)
def test_fit_does_not_read_intermediate_truth(fitted, snake, kind):
    a = fitted[(kind, 12)]
    b = zoo.make(kind, preset="tiny", device="cpu").fit(scrambled_truth(snake, 1))
    sa, sb = a.net_.state_dict(), b.net_.state_dict()
    assert sa.keys() == sb.keys()
    for k in sa:
        assert torch.equal(sa[k], sb[k]), k
    np.testing.assert_array_equal(a.predict(snake), b.predict(snake))


@pytest.mark.parametrize("kind", KINDS)
@pytest.mark.parametrize("n_inputs", [8, 60])  # unit form, and end to end for N = 12
def test_paper_preset_is_sized_like_f_theta(kind, n_inputs):
    cfg, _ = baseline_config(kind, "paper", n_inputs)
    assert abs(count_parameters(build_baseline(cfg)) - 400_000) <= 0.25 * 400_000


def test_settings_are_checked(single, snake, tmp_path):
    with pytest.raises(ConfigError, match="single-passage"):
        zoo.make("mlp", preset="tiny", mode="unit").fit(snake)
    with pytest.raises(ConfigError, match="mode"):
        zoo.make("mlp", preset="tiny", mode="sideways").fit(snake)
    with pytest.raises(ConfigError, match="preset"):
        zoo.make("lstm", preset="huge").fit(snake)
    one = single.select([single.trajectories[0]])
    with pytest.raises(ConfigError, match="two trajectories"):
        zoo.make("mlp", preset="tiny").fit(one)
    m = zoo.make("mlp", preset="tiny", val_fraction=0.0, device="cpu").fit(one)  # no early stopping
    assert len(m.history_["epochs"]) == 3 and m.history_["best_val"] is None
    m.save(tmp_path / "no-val")
    json.loads((tmp_path / "no-val" / "model.json").read_text(), parse_constant=lambda c: pytest.fail(f"non-JSON {c}"))
    with pytest.raises(zoo.NotFittedError):
        zoo.make("transformer").predict(single)


def test_end_to_end_on_a_single_passage(single):
    m = zoo.make("transformer", preset="tiny", mode="end-to-end", window=8, device="cpu").fit(single)
    assert m.mode_ == "end-to-end" and m.net_.cfg.n_inputs == 10 and m.net_.cfg.window == 8
    assert m.predict(single).shape == (single.n_frames, 2, 3)
