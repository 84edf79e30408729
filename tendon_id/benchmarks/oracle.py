"""The blocks that model the simulator's effects at their true settings: the oracle of the diagnosis benchmark.

Each simulator effect (:doc:`/guide/simulator`), and each option of one that the diagnosis names
(:data:`tendon_id.sim.effects.EFFECT_OPTIONS`: ``smooth_edge``), has a candidate block
(:data:`tendon_id.zoo.blocks.EFFECT_BLOCKS`).
:func:`oracle_blocks` sets those blocks to the simulator's parameters, and the routing wrap and
the clearance to the robot's (the truth that no fitted model reads), so a capstan model
with them and the true law is the simulator's noise-free transmission, which
``tests/diagnosis/test_blocks.py`` checks frame by frame.
"""

from __future__ import annotations

from tendon_id.errors import ConfigError
from tendon_id.sim.effects import EFFECT_OPTIONS, Effects
from tendon_id.zoo.blocks import EFFECT_BLOCKS, Block, RoutingWrap


def oracle_block(name: str, effects: Effects, robot=None) -> Block:
    """The candidate block of effect ``name`` at the settings ``effects`` gives it.

    ``robot`` (a :class:`~tendon_id.geometry.RobotGeometry`, the simulated one) gives the contact
    block its true clearance, ``robot.alpha_c``.

    Raises
    ------
    ConfigError
        For an effect or a setting no block models (a Stribeck dip, a motion-driven stick/slip),
        and for contact without the robot.
    """
    if name not in EFFECT_BLOCKS:  # candidate blocks come with the diagnosis issue
        raise ConfigError(f"no candidate block models the simulator effect {name!r} yet")
    cls = EFFECT_BLOCKS[name]
    if name in EFFECT_OPTIONS:  # an option of another effect: smooth_edge of stick_slip
        effect = EFFECT_OPTIONS[name][0]
        if not effects.has(name):
            raise ConfigError(f"{name} is an option of {effect}, which these settings do not switch on")
        return cls(width=effects.get(effect).edge_width)
    p = effects.get(name)
    if name == "stick_slip":
        if p.driver != "tension":
            raise ConfigError("no candidate block models a motion-driven stick/slip (stick_slip.driver = 'motion')")
        return cls()
    if name == "viscoelastic":
        return cls(tau_v=p.tau_v, kappa=p.kappa)
    if name == "velocity_friction":
        if p.stribeck_drop != 0:
            raise ConfigError("no candidate block models a Stribeck dip (velocity_friction.stribeck_drop)")
        return cls(viscous=1.0 / p.v_ref)
    if name == "bending_stiffness":
        return cls(dT_b=p.dT_b)
    if name == "guide_wear":
        return cls(guides=tuple(p.guides), excess=tuple(w - 1.0 for w in p.guides.values()))
    if name == "per_tendon_wrap":
        return cls(model=p.model)
    if name == "sensor_bias":
        return cls(offset=p.offset, gain=p.gain, drift=p.drift)
    if robot is None:
        raise ConfigError("the contact block's true clearance is the simulated robot's alpha_c: pass robot")
    return cls(alpha_c=robot.alpha_c, gate=p.gate)  # contact


def oracle_blocks(effects: Effects, robot) -> tuple[Block, ...]:
    """The blocks of every effect and option that is on, at its true settings, in the simulator's order.

    Then the routing wrap at the simulated robot's ``robot.alpha_0`` (every capstan model has one).
    """
    names = [n for n in effects.enabled]
    for option, (effect, _, _) in EFFECT_OPTIONS.items():
        if effects.has(option):
            names.insert(names.index(effect) + 1, option)
    return tuple(oracle_block(name, effects, robot) for name in names) + (RoutingWrap(alpha_0=robot.alpha_0),)
