"""``tendon-id calibrate``: the calibration and posterior files of DESIGN §10."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from tendon_id.atomic import atomic_write, write_json_atomic
from tendon_id.data import Recording
from tendon_id.errors import ConfigError
from tendon_id.posterior import sample_posterior
from tendon_id.report.html import pyplot
from tendon_id.zoo.capstan import CapstanModel
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


def run_calibration(
    recordings: Sequence[Recording], *, model: str, tying: str, posterior: bool, out: str | Path, seed: int = 0
) -> list[Path]:
    """Calibrate, write ``calibration.json`` (and with ``posterior``, ``posterior.json`` and ``corner.png``)."""
    if not issubclass(model_class(model), CapstanModel):
        raise ConfigError(
            f"--model {model}: calibration needs a capstan-family model ({', '.join(names_of(CapstanModel))})"
        )
    m = make(model, tying=tying, seed=seed)
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    m.fit(recordings)
    written = [write_json_atomic(out / "calibration.json", calibration_json(m, recordings))]
    written.append(m.save(out / "model"))
    if posterior:
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
