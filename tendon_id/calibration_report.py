"""``tendon-id calibrate``: the calibration and posterior files of DESIGN §10."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

from tendon_id.atomic import atomic_write, write_json_atomic
from tendon_id.data import Recording
from tendon_id.errors import ConfigError
from tendon_id.posterior import sample_posterior
from tendon_id.report.html import pyplot
from tendon_id.zoo.capstan import CapstanModel
from tendon_id.zoo.passage import PassageCapstan, PassageInputs
from tendon_id.zoo.passage.fitting import confounded_groups
from tendon_id.zoo.passage.posterior import sample_passage_posterior
from tendon_id.zoo.registry import make, model_class, names_of


def calibration_json(model: CapstanModel, recordings: Sequence[Recording]) -> dict:
    """``{"model", "tying", "A", "B", "mu0", "terminal": M}``; tied: 3 numbers each, per-guide: N-1 lists of 3."""

    def shape(a: np.ndarray):
        return a[0].tolist() if model.tying == "tied" else a.tolist()

    return {
        "model": model.name,
        "tying": model.tying,
        "A": shape(model.A_),
        "B": shape(model.B_),
        "mu0": shape(model.mu0_),
        "terminal": model.score(recordings)["terminal"],
        "calibration": model.calibration_,
        "frames": int(sum(r.n_frames for r in recordings)),
    }


#: Split R-hat below which the chains count as mixed (Vehtari et al. 2021 recommend 1.01; emcee's
#: walkers are not independent chains, so the looser 1.05 of Gelman et al.'s BDA3 is used).
RHAT_MIXED = 1.05


def passage_calibration_json(model: PassageCapstan, inputs: PassageInputs) -> dict:
    """``{"model", "blocks", "direction", "quantity", "unit", "theta", "predicted": M, "correlation", ...}``."""
    return {
        "model": model.name,
        "blocks": list(model.blocks),
        "direction": model.direction,
        "side": model.side,
        "quantity": inputs.quantity,
        "unit": "N m" if inputs.quantity == "torque" else "N",
        "theta": model.theta_,
        "predicted": model.score(inputs)["predicted"],
        "calibration": model.calibration_,
        "correlation": model.calibration_.get("correlation"),
        "confounded": confounded_groups(list(model.theta_), model.calibration_.get("correlation")),
        "frames": int(inputs.output.shape[0]),
    }


def run_calibration(
    recordings: Sequence,
    *,
    model: str,
    tying: str | None = None,
    blocks: Sequence[str] = (),
    posterior: bool,
    out: str | Path,
    seed: int = 0,
    report: Callable[[str], None] | None = None,
) -> list[Path]:
    """Calibrate, write ``calibration.json`` (and with ``posterior``, ``posterior.json`` and ``corner.png``).

    ``model`` is a capstan-family model of the snake (with ``tying``), or ``passage-capstan``
    for a bench's passage (with its effect ``blocks``).
    """
    cls = model_class(model)
    passage = issubclass(cls, PassageCapstan)
    if not (passage or issubclass(cls, CapstanModel)):
        raise ConfigError(
            f"--model {model}: calibration needs a capstan-family model ({', '.join(names_of(CapstanModel))}) "
            "or passage-capstan"
        )
    if passage and tying is not None:
        raise ConfigError("--tying: a passage has one law, there is nothing to tie (leave --tying out)")
    if blocks and not passage:
        raise ConfigError(f"--blocks: the effect blocks are passage-capstan's; {model} has its own settings")
    if passage:
        m = make(model, blocks=list(blocks))
        data = PassageInputs.from_recordings(recordings)
    else:
        m = make(model, tying=tying or "tied", seed=seed)
        data = recordings
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    m.fit(data)
    doc = passage_calibration_json(m, data) if passage else calibration_json(m, recordings)
    written = [write_json_atomic(out / "calibration.json", doc)]
    if passage:
        report(
            f"{m.name} {list(m.blocks)}: {m.side} RMSE {doc['predicted']['rmse']:.3g} {doc['unit']} "
            f"on {doc['frames']} frames"
        )
        for group in doc["confounded"]:
            report(f"the data pins a combination of {', '.join(group)}, not each (|correlation| > 0.99)")
    written.append(m.save(out / "model"))
    if posterior:
        if passage:
            post = sample_passage_posterior(m, data, seed=seed)
            doc = post.to_json()
            mixed = doc["max_rhat"] < RHAT_MIXED
            report(
                f"posterior: {post.samples.shape[0]} draws, ESS >= {doc['min_ess']:.0f}, R-hat <= {doc['max_rhat']:.3f}"
                + ("" if mixed else f" (not yet mixed: R-hat above {RHAT_MIXED}; the intervals are too narrow)")
            )
        else:
            post = sample_posterior(m, recordings, seed=seed)
            doc = {
                "parameters": post.summary(),
                "tau": float(np.max(post.tau)),
                "seconds": post.seconds,
                "acceptance": post.acceptance,
                "walkers": int(post.chain.shape[1]),
                "steps_kept": int(post.chain.shape[0]),
            }
        written.append(write_json_atomic(out / "posterior.json", doc))
        fig = post.corner()
        written.append(atomic_write(out / "corner.png", lambda tmp: fig.savefig(tmp, format="png", dpi=90)))
        pyplot().close(fig)
    return written
