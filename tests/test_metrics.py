import numpy as np
import pytest

from tendon_id.metrics import frame_weighted, tendon_metrics


def test_tendon_metrics_golden():
    true = np.array([[1.0, 2.0, 3.0], [3.0, 2.0, 5.0], [5.0, 2.0, 7.0]])
    pred = true + np.array([[1.0, 0.0, -2.0], [1.0, 0.0, 2.0], [1.0, 0.0, 2.0]])
    m = tendon_metrics(pred, true)
    # Per tendon RMSE: 1, 0, 2 -> mean 1. Max errors: 1, 0, 2 -> mean 1.
    assert m["rmse"] == pytest.approx(1.0)
    assert m["max_error"] == pytest.approx(1.0)
    # R^2 per tendon: 1 - 3/8, nan (constant truth, ignored), 1 - 12/8 -> mean of the two.
    assert m["r2"] == pytest.approx(((1 - 3 / 8) + (1 - 12 / 8)) / 2)


def test_frame_weighted_reproduces_the_papers_overall_proximal_row():
    rows = [
        {"rmse": 48.522, "r2": -0.655, "max_error": 0.0},
        {"rmse": 73.075, "r2": -2.747, "max_error": 0.0},
        {"rmse": 32.699, "r2": 0.486, "max_error": 0.0},
    ]
    overall = frame_weighted(rows, [800, 500, 1260])
    assert overall["rmse"] == pytest.approx(45.530, abs=1e-3)
    assert overall["r2"] == pytest.approx(-0.502, abs=1e-3)


def test_shape_errors():
    with pytest.raises(ValueError):
        tendon_metrics(np.zeros((3, 3)), np.zeros((4, 3)))
    with pytest.raises(ValueError):
        frame_weighted([], [])
