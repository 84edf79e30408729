"""``tendon-id calibrate``: fit a model's law, and optionally sample its posterior, into files (:doc:`/cli`).

Written once for every transmission family: the model's family says what ``calibration.json``
holds (:meth:`~tendon_id.family.Family.calibration_doc`) and what to print about it; the
posterior is :func:`~tendon_id.calibration.posterior.sample_posterior`'s.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path

from tendon_id.atomic import atomic_write, write_json_atomic
from tendon_id.checks import check_choice, check_finite_result
from tendon_id.family.registry import family_names, get_family
from tendon_id.report.html import pyplot
from tendon_id.zoo.registry import make, model_class

__all__ = ["RHAT_MIXED", "calibration_model", "fit_calibration", "law_models", "run_calibration", "write_calibration"]

#: Split R-hat below which the chains count as mixed (Vehtari et al. 2021 recommend 1.01; emcee's
#: walkers are not independent chains, so the looser 1.05 of Gelman et al.'s BDA3 is used).
RHAT_MIXED = 1.05


def sample_posterior(model, recordings, **options):
    """:func:`tendon_id.calibration.posterior.sample_posterior`, imported when a posterior is asked for.

    The sampler loads emcee, ArviZ and scipy.stats, seconds of start-up that a calibration without
    a posterior, and every worker of a fleet (:mod:`tendon_id.report.fleet`), does without.
    """
    from tendon_id.calibration import posterior

    return posterior.sample_posterior(model, recordings, **options)


def law_models() -> list[str]:
    """Every registered model with a law that ``calibrate`` fits, family by family."""
    return [name for f in family_names() for name in get_family(f).law_models()]


def calibration_model(model: str, settings: dict | None = None, seed: int = 0):
    """The unfitted model that ``calibrate`` fits: ``model`` with ``settings`` (and ``seed`` where it takes one).

    Raises
    ------
    ConfigError
        Before any data is read: for a model without a law, or a setting or block it does not have.
    """
    check_choice("model", model, law_models(), what="model with a law")
    settings = dict(settings or {})
    if "seed" in model_class(model).param_names():
        settings.setdefault("seed", seed)
    m = make(model, **settings)
    m.check_settings()
    return m


def fit_calibration(recordings: Sequence, *, model: str, settings: dict | None = None, seed: int = 0):
    """Calibrate ``model`` on ``recordings`` and build its ``calibration.json``, writing nothing.

    The part of :func:`run_calibration` that computes, so that a fleet
    (:func:`tendon_id.report.fleet.calibrate_fleet`) can run it in a worker and write in the caller.

    Parameters
    ----------
    recordings : sequence of recordings
        Of the model's family.
    model : str
        A registered model with a law (:func:`law_models`).
    settings : dict, optional
        The model's settings; ``seed`` is added where the model takes one.
    seed : int
        Seeds the multi-start.

    Returns
    -------
    fitted : Estimator
        The calibrated model.
    doc : dict
        What ``calibration.json`` holds (:meth:`~tendon_id.family.Family.calibration_doc`).

    Raises
    ------
    ConfigError
        For a model without a law, a setting it does not have, or recordings of another family.
    NonFiniteResult
        For a fit or a figure of ``calibration.json`` that came out NaN or infinite, naming the files.
    """
    m = calibration_model(model, settings, seed)
    recordings = m.family.recordings(recordings, "recordings")
    m.fit(recordings)
    inputs = ", ".join(sorted({str(r.source) for r in recordings if r.source})) or "its data"
    m.check_finite_fit(inputs)
    doc = m.family.calibration_doc(m, recordings)
    # R^2 is undefined (null) for a constant reference; every other number is a result.
    check_finite_result(doc, what=f"calibrating {model}", inputs=inputs, undefined=("r2",))
    return m, doc


def write_calibration(fitted, doc: dict, out: str | Path, *, report: Callable[[str], None] | None = None) -> list[Path]:
    """Write ``out/calibration.json`` (``doc``) and the model folder ``out/model``; each file atomically.

    Parameters
    ----------
    fitted : Estimator
        The calibrated model (:func:`fit_calibration`).
    doc : dict
        Its ``calibration.json``.
    out : path-like
        The output folder (created).
    report : callable, optional
        Called with each line the model's family prints about ``doc``.

    Returns
    -------
    list of Path
        ``out/calibration.json`` and ``out/model``.
    """
    report = report or (lambda line: None)
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    written = [write_json_atomic(out / "calibration.json", doc)]
    for line in fitted.family.calibration_lines(fitted, doc):
        report(line)
    written.append(fitted.save(out / "model"))
    return written


def run_calibration(
    recordings: Sequence,
    *,
    model: str,
    settings: dict | None = None,
    posterior: bool = False,
    out: str | Path,
    seed: int = 0,
    report: Callable[[str], None] | None = None,
) -> list[Path]:
    """Calibrate, and write ``calibration.json`` and the model (``posterior``: ``posterior.json``, ``corner.png``).

    Parameters
    ----------
    recordings : sequence of recordings
        Of the model's family.
    model : str
        A registered model with a law (:func:`law_models`).
    settings : dict, optional
        The model's settings (a snake capstan model's ``tying``, a passage model's ``blocks``);
        ``seed`` is added where the model takes one.
    posterior : bool
        Also sample the posterior.
    out : path-like
        The output folder (created).
    seed : int
        Seeds the multi-start and the sampler.
    report : callable, optional
        Called with each line worth printing (default: none printed).

    Returns
    -------
    list of Path
        The files and folders written.

    Raises
    ------
    ConfigError
        For a model without a law, a setting it does not have, or recordings of another family.
    """
    report = report or (lambda line: None)
    out = Path(out)
    m, doc = fit_calibration(recordings, model=model, settings=settings, seed=seed)
    # written before the posterior is sampled: a Ctrl-C in the sampler keeps the calibration
    written = write_calibration(m, doc, out, report=report)  # after the fit: refused data leaves no folder
    if posterior:
        recordings = m.family.recordings(recordings, "recordings")
        post = sample_posterior(m, recordings, seed=seed)
        doc = post.to_dict()
        mixed = doc["max_rhat"] < RHAT_MIXED
        report(
            f"posterior: {post.samples.shape[0]} draws, ESS >= {doc['min_ess']:.0f}, R-hat <= {doc['max_rhat']:.3f}"
            + ("" if mixed else f" (not yet mixed: R-hat above {RHAT_MIXED}; the intervals are too narrow)")
        )
        written.append(write_json_atomic(out / "posterior.json", doc))
        fig = post.corner()
        written.append(atomic_write(out / "corner.png", lambda tmp: fig.savefig(tmp, format="png", dpi=90)))
        pyplot().close(fig)
    return written
