"""The verdict of a diagnosis: no significant gap, explained, partially explained, or unexplained."""

from __future__ import annotations

import dataclasses

import numpy as np

from tendon_id.diagnosis.result import Verdict
from tendon_id.diagnosis.stats import NoiseFloor


def within_sensors(mse: float, floor: NoiseFloor, settings) -> bool:
    """Whether a held-out mean squared error [N^2] is within what the sensors alone give.

    It is when it is at most ``1 + min_excess`` times the upper quantile of a perfect
    model's (:meth:`~tendon_id.family.Family.noise_floor`).
    """
    return mse <= floor.upper**2 * (1.0 + settings.min_excess)


def paired_margin(settings, structural: bool) -> float:
    """The share by which a better model must lower the base's held-out mean squared error [-].

    ``min_excess`` for a model with free parameters, which absorb some of the
    errors-in-variables error of a model fed noisy inputs (on the benchmark's null cases a
    refitted bending loss lowered the held-out mean squared error by up to 21 %);
    ``min_excess_structural`` for a ``structural`` one (a contact gate, per-tendon wraps),
    which has nothing to absorb it with, so its significance alone guards against chance.
    """
    return settings.min_excess_structural if structural else settings.min_excess


def fixed_margins(ladder: list, settings, structural: set | frozenset = ()) -> list[float]:
    """The paired test's fixed margins of the ladder's first rung, and of its end where that is another model [-]."""
    if len(ladder) < 2:
        return []
    first = [paired_margin(settings, ladder[1].effects[-1] in structural)]
    return first + [settings.min_excess] if len(ladder) > 2 else first


def read_ladder(ladder: list, strained: set | frozenset = ()) -> list:
    """The ladder as the verdict reads it: up to its first ``strained`` rung, a block fitted to the far
    edge of its plausible range, which mimics something and is not named."""
    upto = next((k for k, r in enumerate(ladder) if k and r.effects[-1] in strained), len(ladder))
    return ladder[:upto]


def shows_gap(
    mse0: float,
    floor: NoiseFloor,
    excess_significant: bool,
    paired: list[tuple[float, float]],
    settings,
) -> bool:
    """Whether the base's held-out error shows a gap, by the floor or by a better model on the same frames.

    By the floor: the base's mean squared error ``mse0`` [N^2] is beyond what the sensors alone
    give (:func:`within_sensors`) and its excess over the expected floor is significant
    (``excess_significant``, from its bootstrap interval).  By a paired comparison: a model
    whose improvement is significant, given as ``(mse, margin)`` in ``paired`` (its held-out
    mean squared error [N^2] and :func:`paired_margin`), leaves at most ``1 / (1 + margin)``
    of the base's.  The second test compares two models on the very same frames, so the
    realisation's share of the error (a heavy-tailed ratchet the floor can only bound by its
    upper quantile) cancels in it.
    """
    if excess_significant and not within_sensors(mse0, floor, settings):
        return True
    return any(mse0 >= (1.0 + margin) * mse for mse, margin in paired)


def decide(
    mse0: float,
    floor: NoiseFloor,
    excess_ci: tuple[float, float],
    ladder: list,
    settings,
    strained: set | frozenset = (),
    structural: set | frozenset = (),
    unit: str = "N",
    margins: list[float] | None = None,
    end_floor: NoiseFloor | None = None,
) -> Verdict:
    """Read the verdict off the base's gap and the ladder.

    * ``none``: no gap by :func:`shows_gap`: the base's held-out mean squared error is within
      ``min_excess`` of the upper quantile of a perfect model's (what the sensors alone can
      produce) or its excess over the expected floor is not significant, and neither the
      ladder's first rung nor its end lowers it by its margin on the same frames (every rung
      is a significant improvement): ``margins``, else ``min_excess`` (a first rung without
      free parameters needs only ``min_excess_structural``).
    * ``family``: the first rung's block closes at least ``named_share`` of the gap, but only with a
      parameter at the far edge of its plausible range: the effect is of that family in another
      form (a drift that settles where the block's is linear, say), named with that warning.
    * ``unexplained``: a gap, and no candidate closes a significant part of it, or the ladder
      closes less than ``named_share`` of it, or its strained first rung does (a candidate that
      only mimics an effect outside the library is not named).
    * ``explained``: the ladder closes at least ``explained_share``, or what it leaves is
      within what the sensors alone give (the ``none`` rule applied to the ladder's error: the
      share closed is measured from the expected floor, and one realisation of the sensors
      can sit well above it); ``partial`` in between.

    The ladder is read only up to its first ``strained`` effect: a block whose fit reached the
    far edge of its plausible range is mimicking something, and is not named.

    Parameters
    ----------
    mse0 : float
        Base's held-out mean squared error [N^2].
    floor : NoiseFloor
        The noise floor and its upper quantile [N].
    excess_ci : tuple of float
        Bootstrap interval of ``mse0 - floor.rmse^2`` [N^2].
    ladder : list of Rung
        The base, then each accepted rung.
    settings : DiagnosisSettings
    strained : set of str
        Effects whose fitted parameters reached a bound.
    structural : set of str
        Effects whose blocks have no free parameters.
    unit : str
        Unit of the errors in the text (``N``, or ``N m`` for a torque passage).
    margins : list of float, optional
        The paired test's margins of the first rung, and of the ladder's end where that is another
        model; default the settings' fixed ones (:func:`fixed_margins`).  A diagnosis calibrates
        them on data simulated from the base where its family can
        (:func:`~tendon_id.diagnosis.calibrate.calibrated_margins`).
    end_floor : NoiseFloor, optional
        The noise floor of the ladder's end model (of the ladder as read, up to a strained rung),
        on the same draws as ``floor``.  A model that undoes a lag on its inputs amplifies their
        noise, so even at the truth it errs by more than the base would.  Where its expected
        floor is above ``floor``'s upper figure, what the ladder leaves is within what the
        sensors alone give when it is within either floor.
    """
    # The paired models: the first rung (a structural one with its own margin) and the ladder's end.
    calibrated = margins is not None
    margins = fixed_margins(ladder, settings, structural) if margins is None else margins
    paired = [(r.heldout_rmse**2, m) for r, m in zip(ladder[1:2] + ladder[2:][-1:], margins)]
    if not shows_gap(mse0, floor, excess_ci[0] > 0, paired, settings):
        by = f"by {paired[0][1]:.0%} or more" if paired else f"by {settings.min_excess:.0%} or more"
        if paired and calibrated:
            by += " (its margin from data simulated from the base)"
        return Verdict(
            "none",
            [],
            0.0,
            f"no significant gap: the base's {np.sqrt(mse0):.3g} {unit} is within what the sensors alone give "
            f"(noise floor {floor.rmse:.3g} {unit}, up to {floor.upper:.3g} {unit}), and no better model lowers its "
            f"mean squared error on the same frames {by}",
        )
    if len(ladder) >= 2 and ladder[1].effects[-1] in strained:
        e = ladder[1].effects[-1]
        closed = min(max(ladder[1].gap_closed, 0.0), 1.0)
        if closed >= settings.named_share:
            # A real effect rarely has a block's exact form: a family that closes most of the gap only at the
            # edge of its range is named as the family, with its share and the warning that the form differs.
            return Verdict(
                "family",
                [e],
                1.0 - closed,
                f"the {e} family, in another form: it closes {closed:.0%} of the gap, but only with its "
                f"parameters at the edge of their plausible range, so the effect's form differs from the block's "
                f"({1.0 - closed:.0%} remains)",
            )
        return Verdict(
            "unexplained",
            [],
            1.0 - closed,
            f"unexplained: the best candidate, {e}, closes {ladder[1].gap_closed:.0%} of the gap only by reaching "
            "the edge of its plausible range (physics outside the library?)",
        )
    ladder = read_ladder(ladder, strained)
    if len(ladder) < 2:
        return Verdict("unexplained", [], 1.0, "unexplained: no candidate closes a significant part of the gap")
    closed = min(max(ladder[-1].gap_closed, 0.0), 1.0)
    effects = [e for e in ladder[-1].effects if e != "base"]
    remaining = 1.0 - closed
    mse_end = ladder[-1].heldout_rmse ** 2
    own = end_floor is not None and end_floor.rmse > floor.upper and within_sensors(mse_end, end_floor, settings)
    if within_sensors(mse_end, floor, settings) or own:
        to = (
            f" to the ladder's model (its noise floor {end_floor.rmse:.3g} {unit}, up to {end_floor.upper:.3g} "
            f"{unit}, above the base's {floor.rmse:.3g} {unit}: it amplifies its inputs' noise)"
            if own and not within_sensors(mse_end, floor, settings)
            else ""
        )
        return Verdict(
            "explained",
            effects,
            remaining,
            f"explained by {', '.join(effects)}: what remains ({ladder[-1].heldout_rmse:.3g} {unit}) is within what "
            f"the sensors alone give{to}",
        )
    if closed >= settings.explained_share:
        return Verdict("explained", effects, remaining, f"explained by {', '.join(effects)} ({closed:.0%} of the gap)")
    if closed >= settings.named_share:
        return Verdict(
            "partial", effects, remaining, f"partially explained by {', '.join(effects)}: {remaining:.0%} remains"
        )
    return Verdict(
        "unexplained",
        [],
        remaining,
        f"unexplained: the best ladder ({', '.join(effects)}) closes only {closed:.0%} of the gap",
    )


def is_rival(candidate, top, settings) -> bool:
    """Whether ``candidate`` alone closes nearly as much of the gap as ``top`` does, or more.

    It does when it is significant in the first ranking, closes at least ``named_share`` of the
    gap and at most ``rival_share`` less than ``top``: the data hardly tell the two apart.

    Parameters
    ----------
    candidate, top : CandidateResult
        Two candidates of the first ranking.
    settings : DiagnosisSettings

    Returns
    -------
    bool
    """
    return (
        candidate.effect != top.effect
        and candidate.significant
        and candidate.gap_closed >= settings.named_share
        and candidate.gap_closed >= top.gap_closed - settings.rival_share
    )


def parsimonious_lead(ranked: list, settings) -> list:
    """The first ranking, led by the candidate with the fewest free parameters among the best and its rivals.

    Where the data hardly tell two explanations apart (:func:`is_rival`), the ladder starts from
    the simpler one: the "one standard error" rule of model selection, which picks the simplest
    model within the best one's error of it (Hastie, Tibshirani and Friedman, *The Elements of
    Statistical Learning*, 2nd ed., 2009, Sec. 7.10), with the rivals' tolerance for that error.
    A block with more parameters can mimic a simpler one and absorb some of the noise besides:
    on the benchmark's terminal-bias cases the actuator cells' six parameters (gain and offset
    per tendon) lowered the held-out error below the true structure's, and were named first in
    8 of 15, with the true bias as their rival in every one of those.  Among equals the best stays first.

    Parameters
    ----------
    ranked : list of CandidateResult
        The first ranking, best (lowest held-out error) first.
    settings : DiagnosisSettings

    Returns
    -------
    list of CandidateResult
        The same candidates, the leader first and the others in their order.
    """
    if not ranked or not ranked[0].significant:
        return list(ranked)
    top = ranked[0]
    # A rival at the edge of its range mimics something: it does not lead an unstrained best.
    group = [top] + [c for c in ranked[1:] if is_rival(c, top, settings) and (top.at_bound or not c.at_bound)]
    lead = min(group, key=lambda c: len(c.params))  # min keeps the first (the best) among equals
    return [lead] + [c for c in ranked if c is not lead]


def with_rivals(verdict: Verdict, ranked: list, settings) -> Verdict:
    """The verdict, with the candidates that alone close nearly as much of the gap as the effect it names first.

    A rival (:func:`is_rival`) closes nearly as much of the gap as the named effect, or more
    where the named one leads as the simpler (:func:`parsimonious_lead`): the data hardly tell
    them apart (on terminal-only data a terminal cell's bias and the actuator cells' errors,
    say), and the text says so, so that a user checks both rather than trusting the first.
    """
    if verdict.kind not in ("explained", "partial", "family") or not verdict.effects:
        return verdict
    named = verdict.effects[0]
    top = next((c for c in ranked if c.effect == named), None)
    if top is None:
        return verdict
    rivals = [c for c in ranked if is_rival(c, top, settings)]
    if not rivals:
        return verdict
    told = ", ".join(f"{c.effect} ({min(c.gap_closed, 1.0):.0%})" for c in rivals)
    better = [c for c in rivals if c.gap_closed > top.gap_closed]  # named first as the simpler of these
    how_much = "as much of the gap as" if better else "nearly as much of the gap as"
    text = (
        f"{verdict.text}; alone, {told} closes {how_much} {named} ({min(top.gap_closed, 1.0):.0%})"
        f"{' or more' if better else ''}: these data hardly tell them apart"
    )
    if better:
        more = ", ".join(f"{c.effect} ({len(c.params)})" for c in better)
        text += f", and {named} has fewer free parameters ({len(top.params)}) than {more}"
    return dataclasses.replace(verdict, text=text, rivals=[c.effect for c in rivals])
