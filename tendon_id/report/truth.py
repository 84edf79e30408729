"""The simulator's truth in words, for a page to set beside its finding (the reader can then judge it).

A simulated recording carries its truth in its metadata: the capstan law's ``friction_truth``
``(A_i, B_i)`` per tendon (paper Eq. (5)) and the unmodelled ``effects`` that were on
(:doc:`/guide/simulator`). Real data has neither, and every function here returns ``None`` then.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

#: Plain words for the simulator's effects (their blocks are documented in :doc:`/guide/simulator`).
EFFECT_WORDS = {
    "contact": "the hole's contact gate",
    "stick_slip": "stick–slip (the play operator's hysteresis)",
    "smooth_edge": "a smooth edge of the stick–slip band",
    "elastic_tendon": "elastic tendons (joint motion drives slip)",
    "viscoelastic": "viscoelastic lag",
    "velocity_friction": "speed-dependent friction",
    "bending_stiffness": "bending stiffness",
    "guide_wear": "worn guides",
    "per_tendon_wrap": "per-tendon wraps",
    "sensor_bias": "load-cell bias",
    "actuator_cells": "actuator load-cell gain and offset errors",
    "clock_skew": "clock skew between the sensor streams",
    "load_cell_dynamics": "load-cell lag",
    "friction_drift": "friction that runs in and wears",
}


#: Effects whose state (hysteresis, lag, the guides' wear) a trajectory inherits from the motion before it.
STATEFUL = frozenset({"stick_slip", "viscoelastic", "friction_drift"})


#: Words for an effect under one of its settings (``effect_params``), where the setting changes the physics.
SETTING_WORDS = {
    ("contact", "gate", "dead_zone"): "the hole's clearance (a dead zone on each wrap)",
    ("contact", "gate", "hard"): "the hole's contact gate (a hard step on the whole wrap)",
    ("stick_slip", "driver", "elastic"): "elastic tendons through capstan stick–slip bands at every guide",
    ("stick_slip", "driver", "motion"): "stick–slip driven by the joints' motion (rigid tendons)",
    ("stick_slip", "driver", "tension"): "stick–slip driven by the entering tension (rigid tendons)",
}


def _words(name: str, params: Mapping | None) -> str:
    for (effect, key, value), words in SETTING_WORDS.items():
        if effect == name and params and (params.get(name) or {}).get(key) == value:
            return words
    return EFFECT_WORDS.get(name, name.replace("_", " "))


def effect_words(names, params: Mapping | None = None) -> str:
    """``["contact", "viscoelastic"]`` as "the hole's contact gate and viscoelastic lag".

    ``params`` (a recording's ``effect_params``) picks the words of a setting that changes the
    physics, such as the elastic tendon chain of ``stick_slip``'s ``driver``.
    """
    words = [_words(n, params) for n in names]
    if not words:
        return "none"
    return words[0] if len(words) == 1 else ", ".join(words[:-1]) + " and " + words[-1]


def truth_mu0(meta: Mapping) -> np.ndarray | None:
    """The truth's ``mu(0) = A_i + B_i`` per tendon [-], or None for real data."""
    law = meta.get("friction_truth") if meta else None
    if not law:
        return None
    return np.asarray(law["A"], dtype=float) + np.asarray(law["B"], dtype=float)


def truth_effects(meta: Mapping) -> list[str] | None:
    """The unmodelled effects that were on in the simulation, or None for real data."""
    if not meta or meta.get("friction_truth") is None:
        return None
    return list(meta.get("effects") or [])


def truth_names(meta: Mapping | None) -> set[str]:
    """What a diagnosis may name that the truth has: its effects, the options of them that were on
    (``smooth_edge``, ``elastic_tendon``), and ``start_state`` where each log inherits the state of
    unlogged motion (a continuous session with a stateful effect); empty for real data."""
    if not meta:
        return set()
    names = set(meta.get("effects") or []) | set(meta.get("options") or [])
    if meta.get("session") == "continuous" and names & STATEFUL:
        names.add("start_state")
    return names


def truth_sentence(meta: Mapping) -> str | None:
    """One sentence of what the simulator's truth is, or None for real data."""
    mu0 = truth_mu0(meta)
    if mu0 is None:
        return None
    effects = truth_effects(meta)
    recipe = meta.get("recipe")
    text = (
        f"The simulator's truth{f' ({recipe})' if recipe else ''}: capstan friction mu(0) = A + B = "
        f"{', '.join(f'{m:.2f}' for m in mu0)} per tendon, with {effect_words(effects, meta.get('effect_params'))}"
        + ("" if effects else " and no unmodelled effect")
    )
    if meta.get("session") == "continuous" and effects and set(effects) & STATEFUL:
        text += "; each logged trajectory starts in the state that the unlogged motion before it left"
    return text + "."
