"""The learners' networks for any number n >= 2 of tendons a set (issue 41): widths, shapes, streaming = batch."""

import numpy as np
import pytest
import torch

from learners import Cascade, CascadeInputs, preset
from learners.baselines import baseline_config, build_baseline, predict_log_ratio
from learners.cascade import StreamingCascade
from learners.correction import CorrectedCascade, CorrectionConfig, CorrectionInputs
from learners.streaming_native import unit_macs
from learners.training import fit_feature_norm
from learners.unit import n_features


@pytest.mark.parametrize("n_tendons", [2, 4, 7])
def test_the_unit_reads_five_plus_n_inputs_and_gives_n_ratios(n_tendons):
    cascade = Cascade(3, preset("tiny").unit, n_tendons=n_tendons)
    unit = cascade.units[0]
    assert n_features(n_tendons) == 5 + n_tendons
    assert unit.backbone.body[0].in_features == unit.residual.embed.in_features == 5 + n_tendons
    assert unit.backbone.head.out_features == unit.residual.head.out_features == n_tendons
    assert cascade.feature_mean.shape == cascade.feature_std.shape == (5 + n_tendons,)


def test_three_tendons_is_the_default_and_builds_the_same_weights():
    """The count defaults to the paper's 3, and naming it draws the same weights from the same seed."""
    torch.manual_seed(0)
    default = Cascade(4, preset("tiny").unit)
    torch.manual_seed(0)
    named = Cascade(4, preset("tiny").unit, n_tendons=3)
    assert default.n_tendons == 3
    for (k, a), (_, b) in zip(default.state_dict().items(), named.state_dict().items()):
        assert torch.equal(a, b), k
    cfg = preset("paper").unit
    assert unit_macs(cfg) == unit_macs(cfg, 3)
    assert unit_macs(cfg, 4)[0] > unit_macs(cfg)[0]


@pytest.mark.parametrize("compiled", [True, False])
@pytest.mark.parametrize("tied", [True, False])
@pytest.mark.parametrize("n_tendons", [2, 4])
def test_torch_streaming_equals_batch_for_any_tendon_count(n_tendons, tied, compiled):
    """As tests/zoo/test_pgchtc.py checks for three tendons: float64, the ring caches wrapping four times."""
    torch.manual_seed(0)
    n, L = 5, 23
    cascade = Cascade(n - 1, preset("tiny").unit, tied=tied, n_tendons=n_tendons).double().eval()
    for u in cascade.units:
        torch.nn.init.normal_(u.residual.head.weight, std=0.5)  # a residual that matters
    g = torch.Generator().manual_seed(1)
    f64 = dict(generator=g, dtype=torch.float64)
    sin_q = 0.2 * torch.randn(1, L, n - 1, 4, **f64)
    alpha = 0.05 + 0.3 * torch.rand(1, L, n - 1, **f64)
    log_act = 4.5 + 0.3 * torch.randn(1, L, n, n_tendons, **f64)
    with torch.no_grad():
        batch, log_ratio = cascade(CascadeInputs(sin_q, alpha, log_act, torch.arange(L)[None]), torch.arange(n))
    assert batch.shape == (1, L, n, n_tendons) and log_ratio.shape == (1, L, n - 1, n, n_tendons)
    engine = StreamingCascade(cascade, n, compiled=compiled)
    assert (engine._graph is not None) == compiled
    out = torch.stack([engine.step(sin_q[0, t], alpha[0, t], log_act[0, t]) for t in range(L)])
    torch.testing.assert_close(out, batch[0], rtol=0, atol=1e-10)


def test_feature_normalisation_has_a_channel_per_tendon():
    rng = np.random.default_rng(0)
    cascade = Cascade(3, preset("tiny").unit, n_tendons=4)
    tensions = rng.uniform(100.0, 200.0, (50, 4)) * np.array([1.0, 2.0, 3.0, 4.0])
    fit_feature_norm(cascade, rng.uniform(-1, 1, (50, 3, 4)), rng.uniform(0, 0.3, (50, 3)), tensions)
    np.testing.assert_allclose(cascade.feature_mean[5:].numpy(), tensions.mean(0), rtol=1e-6)
    np.testing.assert_allclose(cascade.feature_std[5:].numpy(), tensions.std(0), rtol=1e-6)


@pytest.mark.parametrize("state_inputs", [True, False])
def test_the_correction_follows_the_tendon_count_and_starts_at_its_prior(state_inputs):
    n_t, frames, n = 4, 6, 4
    cascade = CorrectedCascade(n - 1, CorrectionConfig(hidden=(8, 8), state_inputs=state_inputs), n_tendons=n_t)
    unit = cascade.units[0]
    assert unit.n_inputs == 5 + n_t + (4 * n_t if state_inputs else 0)
    assert unit.body[0].in_features == unit.n_inputs and unit.head.out_features == n_t
    g = torch.Generator().manual_seed(0)
    f64 = dict(generator=g, dtype=torch.float64)
    prior = 0.1 * torch.randn(frames, n - 1, n, n_t, **f64)
    inp = CorrectionInputs(
        torch.randn(frames, n - 1, 4, **f64),
        torch.rand(frames, n - 1, **f64),
        5.0 + torch.randn(frames, n, n_t, **f64),
        prior,
        torch.randn(frames, n - 1, n, n_t, 4, generator=g),
    )
    with torch.no_grad():
        log_joint, log_ratio = cascade(inp, torch.arange(n))
    assert log_joint.shape == (frames, n, n_t) and log_ratio.shape == (frames, n - 1, n, n_t)
    passes = torch.arange(n)[None, :] > torch.arange(n - 1)[:, None]  # set j passes guide k
    torch.testing.assert_close(log_ratio[:, passes], prior[:, passes])  # a zero head: no correction yet


@pytest.mark.parametrize("kind", ["mlp", "lstm", "transformer"])
def test_baseline_nets_give_a_log_ratio_per_tendon(kind):
    cfg, _ = baseline_config(kind, "tiny", n_inputs=9, window=4, n_tendons=4)
    net = build_baseline(cfg)
    assert net.y_mean.shape == (4,) and net(torch.zeros(2, 5, 9)).shape == (2, 5, 4)
    out = predict_log_ratio(net, [np.zeros((7, 9), np.float32), np.zeros((3, 9), np.float32)])
    assert [o.shape for o in out] == [(7, 4), (3, 4)]
    assert baseline_config(kind, "tiny", n_inputs=8)[0].n_tendons == 3
