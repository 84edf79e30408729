"""A non-finite loss stops training cleanly: the best weights seen are restored, bit for bit, and the stop is told."""

import copy
import math

import numpy as np
import pytest
import torch
from torch import nn

from learners.loop import LoopSchedule, NonFiniteLossWarning, TrainingError, run_training


def _toy():
    torch.manual_seed(0)
    net = nn.Sequential(nn.Linear(2, 4), nn.BatchNorm1d(4), nn.Linear(4, 1))  # buffers are restored too
    x = torch.randn(16, 2)
    y = x @ torch.tensor([[1.5], [-2.0]]) + 0.5
    return net, x, y


def _equal(a, b):
    return a.keys() == b.keys() and all(torch.equal(a[k], b[k]) for k in a)


def _poisoned(net, x, y, bad_epoch, snapshots):
    """Batches and a loss that turns NaN in the second batch of epoch ``bad_epoch`` (after one step of it)."""
    epoch = [0]

    def batches():
        if epoch[0]:  # the weights as the previous epoch finished them
            snapshots.append(copy.deepcopy(net.state_dict()))
        epoch[0] += 1
        yield torch.arange(0, 16, 2)
        yield torch.arange(1, 16, 2)

    def batch_loss(b):
        loss = ((net(x[b]) - y[b]) ** 2).mean()
        if epoch[0] == bad_epoch and b[0] == 1:
            loss = loss * float("nan")
        return loss, {"data": float(loss.detach())}

    return batches, batch_loss


@pytest.mark.parametrize("bad_epoch, vals, kept", [(4, [3.0, 1.0, 2.0], 2), (3, [3.0, 2.0], 2)])
def test_a_nan_loss_at_epoch_k_keeps_the_best_weights_before_k(bad_epoch, vals, kept):
    net, x, y = _toy()
    snapshots = []
    batches, batch_loss = _poisoned(net, x, y, bad_epoch, snapshots)
    val = iter(vals)
    schedule = LoopSchedule(lr=0.05, epochs=10, patience=5, weight_decay=0.0)
    with pytest.warns(NonFiniteLossWarning, match=f"toy: the loss became nan at epoch {bad_epoch}") as rec:
        hist = run_training(
            net, list(net.parameters()), schedule, batches=batches, batch_loss=batch_loss, validate=lambda: next(val),
            desc="toy",
        )  # fmt: skip
    assert f"kept the weights of epoch {kept}" in str(rec[0].message)
    assert hist.stopped == {"epoch": bad_epoch, "what": "loss", "value": hist.stopped["value"], "kept_epoch": kept}
    assert math.isnan(hist.stopped["value"])
    assert [e["epoch"] for e in hist.epochs] == list(range(1, bad_epoch + 1))
    assert hist.epochs[-1]["non_finite"] is True and all("non_finite" not in e for e in hist.epochs[:-1])
    assert hist.best_epoch == kept and hist.best_val == min(vals)
    assert len(snapshots) == bad_epoch - 1  # epoch k's batches started, after k - 1 finished epochs
    assert _equal(net.state_dict(), snapshots[kept - 1])  # bitwise, BatchNorm's running statistics included
    assert not net.training
    assert torch.isfinite(net(x)).all()


def test_without_validation_the_last_finished_epoch_is_kept():
    net, x, y = _toy()
    snapshots = []
    batches, batch_loss = _poisoned(net, x, y, 3, snapshots)
    schedule = LoopSchedule(lr=0.05, epochs=10, patience=1, weight_decay=0.0)
    with pytest.warns(NonFiniteLossWarning, match="kept the weights of epoch 2"):
        hist = run_training(
            net, list(net.parameters()), schedule, batches=batches, batch_loss=batch_loss, validate=None
        )  # fmt: skip
    assert hist.best_epoch == 2 and hist.stopped["epoch"] == 3
    assert _equal(net.state_dict(), snapshots[1])
    assert torch.isfinite(net(x)).all()


def test_an_infinite_validation_loss_stops_too_and_keeps_the_best_epoch():
    net, x, y = _toy()
    snapshots = []
    batches, batch_loss = _poisoned(net, x, y, 99, snapshots)
    val = iter([2.0, 1.0, math.inf])
    schedule = LoopSchedule(lr=0.05, epochs=10, patience=5, weight_decay=0.0)
    with pytest.warns(NonFiniteLossWarning, match="validation loss became inf at epoch 3"):
        hist = run_training(
            net, list(net.parameters()), schedule, batches=batches, batch_loss=batch_loss, validate=lambda: next(val)
        )  # fmt: skip
    assert hist.stopped["what"] == "validation loss" and hist.best_epoch == 2
    assert _equal(net.state_dict(), snapshots[1])


def test_a_nan_loss_before_any_epoch_finished_has_nothing_to_keep_and_raises():
    net, x, y = _toy()
    batches, batch_loss = _poisoned(net, x, y, 1, [])
    schedule = LoopSchedule(lr=0.05, epochs=3, patience=5, weight_decay=0.0)
    with pytest.raises(TrainingError, match="the loss became nan at epoch 1"):
        run_training(
            net, list(net.parameters()), schedule, batches=batches, batch_loss=batch_loss, validate=lambda: 1.0
        )  # fmt: skip


# ---- PG-CHTC, through the zoo ---------------------------------------------------------------------


@pytest.fixture(scope="module")
def recording():
    from tendon_id.datasets import load_recipe
    from tendon_id.sim import simulate

    return simulate(load_recipe("snake12-paper"), "posterior-6", seed=3, frames=600).recording


def poison_stage2(monkeypatch, bad_epoch):
    """Make stage 2's training loss NaN from its epoch ``bad_epoch`` on; return the weights after each of its epochs."""
    import learners.training as T

    real_loss, real_eval = T._batch_loss, T._evaluate
    after = []  # the cascade's state after each validated stage-2 epoch

    def batch_loss(cascade, batch, weights, residual):
        loss, parts = real_loss(cascade, batch, weights, residual)
        if residual and torch.is_grad_enabled() and len(after) + 1 >= bad_epoch:
            loss = loss * float("nan")
        return loss, parts

    def evaluate(cascade, data, weights, residual, batch):
        out = real_eval(cascade, data, weights, residual, batch)
        if residual:
            after.append(copy.deepcopy(cascade.state_dict()))
        return out

    monkeypatch.setattr(T, "_batch_loss", batch_loss)
    monkeypatch.setattr(T, "_evaluate", evaluate)
    return after


def test_pgchtc_stopped_by_a_nan_loss_keeps_its_best_stage2_weights_and_predicts(recording, monkeypatch):
    from tendon_id import zoo
    from tendon_id.zoo.guard import quiet_guard

    after = poison_stage2(monkeypatch, bad_epoch=2)
    m = zoo.make("pg-chtc", preset="tiny", prior={"A": [0.1] * 3, "B": [0.2] * 3}, progress=False)
    with quiet_guard(), pytest.warns(NonFiniteLossWarning, match=r"stage 2 \(g_phi\): the loss became nan at epoch 2"):
        m.fit(recording)  # the guard's verdict on so tiny a cascade is beside the point here
    assert len(after) == 1  # epoch 1 finished; epoch 2 broke in its first batch
    assert _equal(m.cascade_.state_dict(), after[0])
    assert m.history_["stage2"][-1]["non_finite"] is True and len(m.history_["stage2"]) == 2
    assert np.isfinite(m.predict(recording)).all()
