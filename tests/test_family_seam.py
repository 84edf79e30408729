"""A third transmission family, written here and nowhere else: the seam is all a new kind of transmission needs.

The toy family is one tendon over one capstan wrap of known angle ``WRAP`` (Euler-Eytelwein,
``T_out = T_in exp(-mu WRAP)``), with two effect blocks:

* ``toy_offset`` (stage ``sensor``): the output load cell reads ``offset`` [N] too much;
* ``toy_viscous`` (stage ``exponent``): friction grows with the input's rate,
  ``mu (1 + c |dT_in/dt|)``, ``c`` [s/N].

Its recording, inputs, blocks, model, fit and refit, strata, signatures and likelihood are the
classes and functions below; it is registered for the length of each test. It runs through
the generic ``diagnose``, ``run_calibration`` (calibrate, with its posterior) and
``check_model``, none of which names it.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np
import pandas as pd
import pytest
from scipy.optimize import least_squares

from tendon_id import zoo
from tendon_id.calibration.posterior import LOG_SIGMA_RANGE, Factor, Likelihood, Posterior, sample_posterior
from tendon_id.data import rules
from tendon_id.data.frame import FrameRecording
from tendon_id.diagnosis import DiagnosisSettings, Library, Split, diagnose, difference_floor, quartile_masks
from tendon_id.errors import ConfigError
from tendon_id.family import BlockRegistry, EffectBlock, Family, Fit, FrameInputs, register_family, unregister_family
from tendon_id.metrics import jacobian_correlation, tendon_metrics
from tendon_id.report.calibration import run_calibration
from tendon_id.zoo.estimator import Estimator
from tendon_id.zoo.testing import check_model

WRAP = np.pi / 2  # [rad]
TRUE_MU, TRUE_OFFSET = 0.3, 2.0


# ---- its data --------------------------------------------------------------------------------
class ToyRecording(FrameRecording):
    """Columns ``trajectory``, ``t`` [s], ``tension_in``, ``tension_out`` [N]."""

    __slots__ = ()

    def __init__(self, frame: pd.DataFrame, meta=None, *, source=None):
        self._source = source
        self._meta = {"sample_rate_hz": 100.0, **dict(meta or {})}
        self._frame = frame.reset_index(drop=True).assign(trajectory=frame["trajectory"].astype(str).to_numpy())
        rules.check_not_empty(self._frame, source=source)
        rules.check_numeric(self._frame, ["t", "tension_in", "tension_out"], source=source)
        ids = rules.check_trajectory_ids(self._frame, source=source)
        rules.check_positive_tensions({c: self.signal(c) for c in ("tension_in", "tension_out")}, source=source)
        rules.check_time_increases(self.signal("t"), ids, source=source)

    def describe(self) -> dict:
        return {"n_frames": self.n_frames, "trajectories": self.trajectories}

    def summary(self, name=None) -> str:
        return f"toy recording {name or self.source or '-'}: {self.n_frames} frames"


@dataclass(frozen=True, eq=False)
class ToyInputs(FrameInputs):
    frame_fields: ClassVar[tuple[str, ...]] = ("tension_in", "tension_out", "reset")

    tension_in: np.ndarray
    tension_out: np.ndarray
    reset: np.ndarray
    dt: float
    cache: dict = field(default_factory=dict, init=False, repr=False, compare=False)

    @classmethod
    def of(cls, recs) -> ToyInputs:
        return cls(
            np.concatenate([r.signal("tension_in") for r in recs]),
            np.concatenate([r.signal("tension_out") for r in recs]),
            np.concatenate([r.trajectory_starts for r in recs]),
            recs[0].dt,
        )

    def rate(self) -> np.ndarray:
        """|dT_in/dt| [N/s], 0 on each trajectory's first frame."""
        d = np.abs(np.diff(self.tension_in, prepend=self.tension_in[0])) / self.dt
        return np.where(self.reset, 0.0, d)


# ---- its blocks --------------------------------------------------------------------------------
TOY_BLOCKS = BlockRegistry("toy")


@dataclass(frozen=True)
class ToyBlock(EffectBlock):
    registry: ClassVar[BlockRegistry] = TOY_BLOCKS
    stages: ClassVar[tuple[str, ...]] = ("exponent", "sensor")
    bounds: ClassVar[dict] = {}
    probes: ClassVar[dict] = {}

    def to_dict(self) -> dict:
        return {"block": self.name}

    def neutral(self) -> dict:
        return {p: 0.0 for p in self.param_names}

    def location(self) -> str:
        return ""


@dataclass(frozen=True)
class ToyOffset(ToyBlock):
    name: ClassVar[str] = "toy_offset"
    effect: ClassVar[str] = "toy_offset"
    stage: ClassVar[str] = "sensor"
    param_names: ClassVar[tuple[str, ...]] = ("offset",)
    bounds: ClassVar[dict] = {"offset": (-20.0, 20.0)}
    probes: ClassVar[dict] = {"offset": 1.0}


@dataclass(frozen=True)
class ToyViscous(ToyBlock):
    name: ClassVar[str] = "toy_viscous"
    effect: ClassVar[str] = "toy_viscous"
    stage: ClassVar[str] = "exponent"
    param_names: ClassVar[tuple[str, ...]] = ("c",)
    bounds: ClassVar[dict] = {"c": (0.0, 1.0)}
    probes: ClassVar[dict] = {"c": 0.05}


# ---- its model -----------------------------------------------------------------------------------
class ToyCapstan(Estimator):
    """``T_out = T_in exp(-mu (1 + c |dT_in/dt|) WRAP) + offset``; ``mu`` is its law."""

    name = "toy-capstan"

    def __init__(self, blocks=(), warmup_s: float = 0.0):
        self.blocks = tuple(blocks)
        self.warmup_s = warmup_s

    @property
    def block_objects(self) -> list:
        return [TOY_BLOCKS.lookup(b)() if isinstance(b, str) else b for b in self.blocks]

    def with_blocks(self, *blocks) -> ToyCapstan:
        names = [b if isinstance(b, str) else b.name for b in blocks]
        return ToyCapstan(blocks=self.blocks + tuple(n for n in names if n not in self.blocks), warmup_s=self.warmup_s)

    def labels(self) -> list[str]:
        return ["mu"] + [f"{b.name}:{p}" for b in self.block_objects for p in b.param_names]

    def box(self) -> tuple[np.ndarray, np.ndarray]:
        bounds = [(0.0, 2.0)] + [b.bounds[p] for b in self.block_objects for p in b.param_names]
        return np.array([lo for lo, _ in bounds]), np.array([hi for _, hi in bounds])

    def reading(self, inputs: ToyInputs, theta: dict) -> np.ndarray:
        c = theta.get("toy_viscous:c", 0.0) if "toy_viscous" in self.blocks else 0.0
        offset = theta.get("toy_offset:offset", 0.0) if "toy_offset" in self.blocks else 0.0
        return inputs.tension_in * np.exp(-theta["mu"] * (1.0 + c * inputs.rate()) * WRAP) + offset

    @property
    def is_fitted(self) -> bool:
        return hasattr(self, "theta_")

    def inputs(self, data) -> ToyInputs:
        self.check_fitted()
        inputs = data if isinstance(data, ToyInputs) else ToyInputs.of(TOY.recordings(data))
        if not np.isclose(inputs.dt, self.dt_):
            raise ConfigError(f"the model was fitted at {1 / self.dt_:g} Hz, the data is at {1 / inputs.dt:g} Hz")
        return inputs

    def fit(self, data) -> ToyCapstan:
        inputs = data if isinstance(data, ToyInputs) else ToyInputs.of(TOY.recordings(data))
        fit = toy_fit(self, inputs, {"mu": 0.5})
        self.theta_, self.dt_ = fit.values, inputs.dt
        return self

    def predict(self, data) -> np.ndarray:
        return self.reading(self.inputs(data), self.theta_)

    def score(self, data) -> dict:
        inputs = self.inputs(data)
        return {"output": tendon_metrics(self.predict(inputs)[:, None], inputs.tension_out[:, None])}

    def _state(self):
        return {"theta": self.theta_, "dt": self.dt_}, {}

    def _restore(self, state, arrays):
        self.theta_, self.dt_ = {k: float(v) for k, v in state["theta"].items()}, float(state["dt"])


def toy_fit(model: ToyCapstan, inputs: ToyInputs, start: dict, max_nfev: int = 200) -> Fit:
    """Bounded least squares of the output from ``start`` (scipy's trust-region reflective)."""
    labels = model.labels()
    lo, hi = model.box()
    x0 = np.clip([start.get(k, 0.0) for k in labels], lo + 1e-6 * (hi - lo), hi - 1e-6 * (hi - lo))

    def residual(x):
        return model.reading(inputs, dict(zip(labels, x))) - inputs.tension_out

    sol = least_squares(residual, x0, bounds=(lo, hi), max_nfev=max_nfev)
    return Fit(
        model=None,
        sse=float(np.sum(sol.fun**2)),
        n_obs=inputs.n_frames,
        labels=labels,
        n_law=1,
        x=sol.x,
        lower=lo,
        upper=hi,
        corr=jacobian_correlation(sol.jac),
        n_eval=int(sol.nfev),
    )


# ---- its family -----------------------------------------------------------------------------
class ToyFamily(Family):
    name = "toy"
    title = "toy wrap"
    recording = ToyRecording
    blocks = TOY_BLOCKS

    def inputs(self, data, model=None):
        return model.inputs(data) if model is not None else ToyInputs.of(self.recordings(data))

    def block_values(self, model, block):
        return {p: model.theta_[f"{block.name}:{p}"] for p in block.param_names}

    def start(self, model):
        return model.theta_

    def merge(self, current, single):
        return {**(single.theta_ if single is not None else {}), **current.theta_}

    def refit(self, structure, inputs, start, max_nfev):
        fit = toy_fit(structure, inputs, start, max_nfev)
        fit.model = ToyCapstan(**structure.get_params())
        fit.model.theta_, fit.model.dt_ = fit.values, inputs.dt
        return fit

    def residual(self, model, inputs):
        return (inputs.tension_out - model.reading(inputs, model.theta_))[:, None]

    def splits(self, train, test, folds, base):
        return [Split(ToyInputs.of(train), ToyInputs.of(test))], "held-out toy files"

    def strata(self, inputs):
        return [(n, "tension", m) for n, m in quartile_masks(inputs.tension_in, "input tension", "N")]

    def signatures(self, structure, fitted, inputs, blocks):
        base = fitted.reading(inputs, fitted.theta_)
        cols = []
        for b in blocks.values():
            probe = {f"{b.name}:{p}": v for p, v in b.probes.items()}
            cols.append(fitted.with_blocks(b).reading(inputs, {**fitted.theta_, **probe}) - base)
        columns = np.stack(cols, axis=-1)[:, None, :] if cols else np.zeros((inputs.n_frames, 1, 0))
        return Library(list(blocks), list(blocks), columns)

    def noise_floor(self, split, model, inputs, residual, rng, settings):
        return difference_floor(residual)

    def likelihood(self, model, data, **options):
        inputs = self.inputs(data, model)
        labels = model.labels()
        lo, hi = model.box()
        resid = self.residual(model, inputs)[:, 0]
        n = inputs.n_frames

        def log_prob(z):
            if np.any(z < lower) or np.any(z > upper):
                return -np.inf
            e = model.reading(inputs, dict(zip(labels, z[:-1]))) - inputs.tension_out
            return -n * z[-1] - 0.5 * float(e @ e) * np.exp(-2.0 * z[-1])

        lower, upper = np.r_[lo, LOG_SIGMA_RANGE[0]], np.r_[hi, LOG_SIGMA_RANGE[1]]
        centre = np.r_[[model.theta_[k] for k in labels], np.log(np.sqrt(np.mean(resid**2)))]
        return Likelihood([Factor(log_prob, centre, lower, upper)], [*labels, "log_sigma"], centre, result=Posterior)

    def law_models(self):
        return ["toy-capstan"]

    def calibration_doc(self, model, recordings):
        return {"model": model.name, "theta": model.theta_, "output": model.score(recordings)["output"]}

    def score_lines(self, model, score, recording, name):
        return [f"{model.name} on {name}", f"RMSE {score['output']['rmse']:.3g} N"]

    def check_predictions(self, model, test):
        pred = model.predict(test)
        assert pred.shape == (test.n_frames,)
        return pred

    def foreign_data(self, test):
        """The same frames at half the sample rate."""
        return ToyRecording(test.frame.assign(t=2.0 * test.frame["t"]), {**test.meta, "sample_rate_hz": 50.0})


TOY = ToyFamily()
ToyRecording.family = ToyCapstan.family = TOY


# ---- data and registration -------------------------------------------------------------------
def toy_recording(seed: int, n: int = 600, offset: float = TRUE_OFFSET) -> ToyRecording:
    """A toy wrap driven by a slow sine, its output with a sensor offset and 0.05 N of noise."""
    rng = np.random.default_rng(seed)
    t = np.arange(n) * 0.01
    tin = 50.0 + 20.0 * np.sin(2 * np.pi * 0.4 * t + seed) + 5.0 * np.sin(2 * np.pi * 1.3 * t)
    tout = tin * np.exp(-TRUE_MU * WRAP) + offset + 0.05 * rng.standard_normal(n)
    return ToyRecording(pd.DataFrame({"trajectory": f"run{seed}", "t": t, "tension_in": tin, "tension_out": tout}))


@pytest.fixture
def registered():
    register_family(TOY)
    zoo.register(ToyCapstan)
    yield
    zoo.unregister("toy-capstan")
    unregister_family("toy")


def test_the_diagnosis_names_the_toy_families_missing_offset(registered):
    train, test = [toy_recording(s) for s in (0, 1)], [toy_recording(s) for s in (2, 3)]
    result = diagnose(ToyCapstan(), train, test, settings=DiagnosisSettings(n_boot=100, block_s=0.5), progress=False)
    top = result.candidates[0]
    assert top.effect == "toy_offset" and top.significant
    assert top.params["offset"] == pytest.approx(TRUE_OFFSET, abs=0.05)
    assert result.verdict.kind == "explained" and result.verdict.effects == ["toy_offset"]
    assert result.ladder[-1].heldout_rmse < 0.1 < result.base_rmse  # down to the 0.05 N noise
    assert {s.kind for s in result.where} == {"tension"}  # the family's strata


def test_calibrate_and_the_posterior_run_the_toy_family(registered, tmp_path):
    recs = [toy_recording(s, offset=0.0) for s in (0, 1)]
    lines = []
    written = run_calibration(recs, model="toy-capstan", posterior=True, out=tmp_path, report=lines.append)
    doc = json.loads((tmp_path / "calibration.json").read_text())
    assert doc["theta"]["mu"] == pytest.approx(TRUE_MU, abs=2e-3)
    post = json.loads((tmp_path / "posterior.json").read_text())
    q = post["parameters"]["mu"]
    assert q["q2.5"] <= TRUE_MU <= q["q97.5"]
    assert np.exp(post["parameters"]["log_sigma"]["mean"]) == pytest.approx(0.05, rel=0.15)
    assert tmp_path / "corner.png" in written and lines[0].startswith("posterior:")
    again = sample_posterior(zoo.load(tmp_path / "model"), recs, seed=0, progress=False)
    assert again.statistics()["mu"]["mean"] == pytest.approx(q["mean"], abs=4 * q["sd"])


def test_check_model_holds_the_toy_model_to_the_zoo_contract(registered):
    check_model(ToyCapstan(blocks=("toy_offset",)), toy_recording(0), toy_recording(1))


def test_a_snake_model_is_refused_toy_data(registered):
    with pytest.raises(ConfigError, match="expected snake chain recordings"):
        diagnose(zoo.make("capstan-simple"), [toy_recording(0)], [toy_recording(1)])
