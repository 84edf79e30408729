"""The shared training loop of learners: early stopping, the weights it keeps, loss reporting, errors."""

import copy
import math

import pytest
import torch
from torch import nn

from learners.loop import LoopSchedule, TrainingError, run_training


def _toy():
    torch.manual_seed(0)
    net = nn.Linear(2, 1)
    x = torch.randn(8, 2)
    y = x @ torch.tensor([[1.5], [-2.0]]) + 0.5
    return net, x, y


def _mse(net, x, y):
    return lambda b: (((net(x[b]) - y[b]) ** 2).mean(), None)


def _recording_batches(net, snapshots, n_batches=2):
    """Yield the batches of an epoch, then snapshot the weights at its end (after the last step)."""

    def batches():
        for i in range(n_batches):
            yield torch.arange(i, 8, n_batches)
        snapshots.append(copy.deepcopy(net.state_dict()))

    return batches


def _equal(a, b):
    return all(torch.equal(a[k], b[k]) for k in a)


def test_patience_stops_early_and_restores_the_best_weights():
    net, x, y = _toy()
    snapshots = []
    vals = iter([1.0, 2.0, 2.0, 0.5])  # best at epoch 1, then two epochs no better: 0.5 is never reached
    schedule = LoopSchedule(lr=0.05, epochs=10, patience=2, weight_decay=0.0)
    hist = run_training(
        net,
        list(net.parameters()),
        schedule,
        batches=_recording_batches(net, snapshots),
        batch_loss=_mse(net, x, y),
        validate=lambda: next(vals),
    )
    assert [e["epoch"] for e in hist.epochs] == [1, 2, 3] and len(snapshots) == 3
    assert hist.best_epoch == 1 and hist.best_val == 1.0
    assert _equal(net.state_dict(), snapshots[0])
    assert not _equal(snapshots[0], snapshots[-1])  # training moved on, and was rolled back
    assert not net.training


def test_best_epoch_in_the_middle_is_the_one_kept():
    net, x, y = _toy()
    snapshots = []
    vals = iter([3.0, 1.0, 2.0, 1.0 - 1e-13, 0.5])  # 1 - 1e-13 is not better by more than 1e-12
    schedule = LoopSchedule(lr=0.05, epochs=10, patience=2, weight_decay=0.0)
    hist = run_training(
        net,
        list(net.parameters()),
        schedule,
        batches=_recording_batches(net, snapshots),
        batch_loss=_mse(net, x, y),
        validate=lambda: next(vals),
    )
    assert len(hist.epochs) == 4 and len(snapshots) == 4
    assert [e["val"] for e in hist.epochs] == [3.0, 1.0, 2.0, 1.0 - 1e-13]
    assert hist.best_epoch == 2 and hist.best_val == 1.0
    assert _equal(net.state_dict(), snapshots[1])
    assert not _equal(snapshots[1], snapshots[3])


def test_without_validation_every_epoch_runs_and_the_last_weights_are_kept():
    net, x, y = _toy()
    before = copy.deepcopy(net.state_dict())
    snapshots = []
    schedule = LoopSchedule(lr=0.05, epochs=4, patience=1, weight_decay=0.0)
    hist = run_training(
        net,
        list(net.parameters()),
        schedule,
        batches=_recording_batches(net, snapshots),
        batch_loss=_mse(net, x, y),
        validate=None,
    )
    assert len(hist.epochs) == 4 and hist.best_epoch == 4 and hist.best_val == math.inf
    assert all(math.isnan(e["val"]) for e in hist.epochs)
    assert _equal(net.state_dict(), snapshots[-1])
    assert not _equal(net.state_dict(), before)
    assert not net.training


@pytest.mark.parametrize("per_epoch, expected", [(None, 2.0), (4, 1.5)])
def test_training_loss_is_averaged_over_steps_or_the_given_batch_count(per_epoch, expected):
    net = nn.Linear(1, 1)
    schedule = LoopSchedule(lr=1e-3, epochs=2, patience=5, weight_decay=0.0)
    hist = run_training(
        net,
        list(net.parameters()),
        schedule,
        batches=lambda: range(3),
        batch_loss=lambda b: (net.weight.sum() * 0.0 + 2.0, None),
        validate=lambda: 1.0,
        batches_per_epoch=per_epoch,
    )
    assert [e["train"] for e in hist.epochs] == [expected, expected]


def test_only_the_given_parameters_move_and_train_mode_is_the_callers():
    net, x, y = _toy()
    frozen = net.bias.detach().clone()
    modes, training = [], []
    loss = _mse(net, x, y)

    def batch_loss(b):
        training.append(net.training)  # the mode the caller's hook chose, not the loop's
        return loss(b)

    schedule = LoopSchedule(lr=0.05, epochs=2, patience=5, weight_decay=0.1)
    run_training(
        net,
        [net.weight],
        schedule,
        batches=lambda: [torch.arange(8)],
        batch_loss=batch_loss,
        validate=None,
        train_mode=lambda: modes.append(net.eval()),
    )
    assert torch.equal(net.bias, frozen)
    assert len(modes) == 2
    assert training == [False, False]


@pytest.mark.parametrize("parts, shown", [({"data": 1.0}, "(parts {'data': 1.0})"), (None, "")])
def test_a_non_finite_loss_stops_with_a_message(parts, shown):
    net = nn.Linear(1, 1)
    schedule = LoopSchedule(lr=1e-3, epochs=3, patience=5, weight_decay=0.0)
    with pytest.raises(TrainingError) as err:
        run_training(
            net,
            list(net.parameters()),
            schedule,
            batches=lambda: range(2),
            batch_loss=lambda b: (net.weight.sum() * float("nan"), parts),
            validate=None,
            desc="toy",
        )
    msg = str(err.value)
    assert msg.startswith("toy: the loss became nan at epoch 1")
    assert ("(parts" in msg) == (parts is not None) and shown in msg
    assert msg.endswith("lower the learning rate or check the data for non-positive tensions")
