"""The blocks that model the simulator's effects at their true settings: the oracle of the diagnosis benchmark.

Each simulator effect (:doc:`/guide/simulator`), and each option of one that the diagnosis names
(:data:`tendon_id.sim.effects.EFFECT_OPTIONS`: ``smooth_edge``, ``elastic_tendon``), has a candidate block
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


def oracle_block(name: str, effects: Effects, robot=None, sensor_truth: dict | None = None) -> Block:
    """The candidate block of effect ``name`` at the settings ``effects`` gives it.

    ``robot`` (a :class:`~tendon_id.geometry.RobotGeometry`, the simulated one) gives the contact
    block its true clearance, ``robot.alpha_c``; ``sensor_truth`` (a recording's
    ``meta["sensor_truth"]``) the actuator cells' drawn errors, of which the block takes the
    terminal set's (the cells the labels see).

    Raises
    ------
    ConfigError
        For an effect or a setting no block models (a Stribeck dip, a motion-driven stick/slip),
        and for contact without the robot.
    """
    if name not in EFFECT_BLOCKS:  # candidate blocks come with the diagnosis issue
        raise ConfigError(f"no candidate block models the simulator effect {name!r} yet")
    cls = EFFECT_BLOCKS[name]
    if name == "start_state":  # no setting: the observer of the state a continuous session leaves each log in
        return cls()
    if name in EFFECT_OPTIONS:  # an option of another effect: smooth_edge or elastic_tendon of stick_slip
        effect = EFFECT_OPTIONS[name][0]
        if not effects.has(name):
            raise ConfigError(f"{name} is an option of {effect}, which these settings do not switch on")
        p = effects.get(effect)
        return cls(width=p.edge_width) if name == "smooth_edge" else cls(EA_kN=p.EA / 1e3)
    p = effects.get(name)
    if name == "stick_slip":
        if p.driver == "motion":
            raise ConfigError("no candidate block models a motion-driven stick/slip (stick_slip.driver = 'motion')")
        return cls()  # the elastic chain is the option elastic_tendon, which refines this block
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
        if p.drift_form != "linear":
            raise ConfigError("no candidate block models a warm-up drift (sensor_bias.drift_form = 'warm_up')")
        return cls(offset=p.offset, gain=p.gain, drift=p.drift)
    if name == "clock_skew":  # the terminal stream against the inputs, which share one instant here
        if p.angles_s != p.actuator_s:
            raise ConfigError("the clock_skew block shifts the terminal stream against inputs sampled together")
        return cls(skew_s=p.terminal_s - p.actuator_s)
    if name == "load_cell_dynamics":
        if p.order != 1:
            raise ConfigError("no candidate block models a second-order load cell (load_cell_dynamics.order = 2)")
        return cls(tau_s=p.tau_s)  # the exact form, the truth's structure (the diagnosis's candidate is commuted)
    if name == "friction_drift":
        if p.form != "exponential":
            raise ConfigError("no candidate block models a hyperbolic run-in (friction_drift.form = 'hyperbolic')")
        return cls(
            run_in_drop=p.run_in_drop,
            wear_rate_per_m=p.wear_rate_per_m,
            run_in_length_m=p.run_in_length_m,
            prior_sliding_m=p.prior_sliding_m,
        )
    if name == "actuator_cells":
        cells = (sensor_truth or {}).get("actuator_cells")
        if cells is None:
            raise ConfigError("the actuator cells' drawn errors are the recording's sensor_truth: pass it")
        gain, offset = cells["gain"][-1], cells["offset"][-1]  # the terminal set's cells
        m = len(gain)  # tendons per set
        cells = {**{f"gain_{i + 1}": gain[i] for i in range(m)}, **{f"offset_{i + 1}": offset[i] for i in range(m)}}
        return cls(n_tendons=m, **cells)
    if robot is None:
        raise ConfigError("the contact block's true clearance is the simulated robot's alpha_c: pass robot")
    return cls(alpha_c=robot.alpha_c, gate=p.gate)  # contact


def oracle_blocks(effects: Effects, robot, sensor_truth: dict | None = None) -> tuple[Block, ...]:
    """The blocks of every effect and option that is on, at its true settings, in the simulator's order.

    Then the routing wrap at the simulated robot's ``robot.alpha_0`` (every capstan model has one).
    """
    names = [n for n in effects.enabled]
    for option, (effect, _, _) in EFFECT_OPTIONS.items():
        if effects.has(option):
            names.insert(names.index(effect) + 1, option)
    blocks = tuple(oracle_block(name, effects, robot, sensor_truth) for name in names)
    return blocks + (RoutingWrap(alpha_0=robot.alpha_0),)
