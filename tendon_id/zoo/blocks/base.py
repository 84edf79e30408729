"""The block contract: stages, the context a hook sees, and self-registration.

A capstan model propagates ``ln T`` of each tendon through the guides, proximal to
distal (paper Algorithm 1 with analytic ratios).  A block acts at one stage (and at
the stages of :attr:`Block.also`, for one effect seen in two places: a load cell's lag on the
actuator-side and terminal cells), and every block of a stage has the same hook (``values`` holds
the block's parameters, ``{param: value}``; ``ctx`` is a :class:`HookContext`):

==================  =========================================  ==============================
stage               hook                                       what it changes
==================  =========================================  ==============================
``actuator``        ``actuator(t, ctx, values) -> t``          the tensions entering the chain
                                                               [N], from the actuator-side
                                                               readings
``wrap``            ``wrap(alpha, ctx, values) -> alpha``      the wrap the law sees
``routing``         ``routing(alpha, ctx, values) -> alpha``   the routing wrap added to it
``exponent``        ``exponent(phi, ctx, values) -> phi``      the capstan exponent; linear in
                                                               ``phi`` (a friction multiplier,
                                                               or a filter over time)
``edges``           ``edges(lo, hi, ctx, values) -> lo, hi``   a guide's slip edges
``start``           ``start(log_in, phi, n_pass, ctx,          the share of each guide's band
                    values) -> share``                         a trajectory starts at (default
                                                               0: taut, forward slip)
``propagate``       ``propagate(lo, hi, ctx, values) -> y``    the step between the edges
                                                               (default: forward slip, ``lo``)
``guide_output``    ``guide_output(y, ctx, values) -> y``      the tension leaving a guide
``sensor``          ``sensor(t, ctx, values) -> t``            the terminal reading [N]
==================  =========================================  ==============================

The ``actuator`` stage sees the actuator-side readings of the propagated sets and tendons,
``ctx.sets`` and ``ctx.tendons``, shape ``(T, S, m)``, and the ``sensor`` stage the predicted
terminal reading, shape ``(T, m)``.  Both are a load cell's measurement chain, whose blocks
run in the physical order :attr:`Block.measurement_order` gives: the sensor stage applies
the cell's lag, then its sampling instant, then its calibration; the actuator stage undoes
them in reverse.  The ``wrap``, ``routing`` and ``exponent`` stages act on arrays over all
guides, shape ``(T, K, S, m)`` (or broadcastable: ``(T, K, 1, 1)`` when every set and tendon
sees the backbone wrap); the three per-guide stages see one guide, ``ctx.guide``, and
arrays of shape ``(T, S_g, m)`` for the sets that pass it.  The wrap stage starts from the
joints' part of the backbone wrap (``|theta_k| / 2 + |theta_{k+1}| / 2``); the routing wrap,
which no user measures, is a fitted parameter of the routing stage
(:class:`~tendon_id.zoo.blocks.geometric.RoutingWrap`, in every capstan model).

Each block declares the simulator effect it models (:attr:`Block.effect`, :doc:`/guide/simulator`),
its free parameters with bounds and neutral initial values (a model with the block
added starts from its base model's fit), and a probe: a typical magnitude of each
parameter, from which the sim-to-real diagnosis builds the block's signature
regressor (:meth:`Block.signature`).  A *geometric* block's parameters describe the robot
(a clearance, a routing wrap): the law problem stays linear at any fixed value of them, so
calibration profiles them out (:mod:`tendon_id.calibration.law_geometry`), and their
starting values may come from the robot's measured sizes (:meth:`Block.started_from`).
Subclasses that set ``name`` register
themselves in the snake chain's registry, :data:`BLOCKS` (the declarations every family's
blocks share are :class:`~tendon_id.family.blocks.EffectBlock`'s).
"""

from __future__ import annotations

from dataclasses import dataclass, field, fields, replace
from typing import Any, ClassVar

import numpy as np
from numpy.typing import NDArray

from tendon_id.family.blocks import BlockRegistry, EffectBlock

STAGES = ("actuator", "wrap", "routing", "exponent", "edges", "start", "propagate", "guide_output", "sensor")

#: The snake chain's blocks, filled as each block class is defined.
BLOCKS = BlockRegistry("snake")
#: Every block class by name.
BLOCK_TYPES: dict[str, type[Block]] = BLOCKS.by_name
#: The block class that models each simulator effect (docs/guide/simulator.rst names).
EFFECT_BLOCKS: dict[str, type[Block]] = BLOCKS.by_effect


@dataclass(frozen=True)
class HookContext:
    """What a block's hook sees besides the array it transforms: the data, and which sets and guide.

    Attributes
    ----------
    inputs : TransmissionInputs
        The data (angles, actuator tensions, resets, clock, geometry).
    sets, tendons : ndarray of int
        0-based set and tendon indices being propagated.
    alpha : ndarray, optional
        Wrap after the ``wrap`` and ``routing`` stages [rad], shape ``(T, K, S, m)`` or ``(T, K, 1, 1)``.
    guide : int, optional
        0-based guide index, in the per-guide stages.
    active : ndarray of bool, optional
        Which of ``sets`` pass ``guide``.
    """

    inputs: Any
    sets: NDArray[np.int_]
    tendons: NDArray[np.int_]
    alpha: NDArray | None = None
    guide: int | None = None
    active: NDArray[np.bool_] | None = None

    def at_guide(self, guide: int, active: NDArray[np.bool_]) -> HookContext:
        return replace(self, guide=guide, active=active)

    @property
    def guide_alpha(self) -> NDArray:
        """Wrap at ``guide`` for the sets passing it, shape ``(T, S_g, m)`` or ``(T, 1, 1)`` [rad]."""
        a = self.alpha[:, self.guide]
        return a[:, self.active] if a.shape[1] > 1 else a


@dataclass(frozen=True)
class Block(EffectBlock):
    """Base of the snake chain's effect blocks (see the module docstring).

    Attributes
    ----------
    name : str
        Registry name (what a saved model stores).
    effect : str or None
        The simulator effect it models (:doc:`/guide/simulator`), or None.
    stage : str
        One of :data:`STAGES`.
    also : tuple of str
        Further stages the block acts at, with their hooks (class attribute): one effect seen in
        several places (a load cell's lag: undone on the actuator-side readings and applied to the
        terminal one, or, to first order, applied to the wrap, each in one of its forms).
    measurement_order : int
        Where the effect sits in a load cell's measurement chain (class attribute), for the
        ``actuator`` and ``sensor`` stages: 0 the cell's lag, 1 the instant it is sampled at, 2
        its calibration (the default).  Ties keep the model's order.
    whole_chain : bool
        The block acts on every guide of a tendon at once, through the compiled pass over the
        chain (:meth:`propagate_series`), never guide by guide (class attribute): a model with it
        has no ``edges`` or ``guide_output`` block.
    per_tendon : bool
        The block's factor differs by set or tendon (it cannot enter the linear design
        of :class:`~tendon_id.calibration.problem.LawProblem`).
    multiplier : bool
        The ``exponent`` hook multiplies the exponent frame by frame (class attribute; default
        True).  False for a filter over time (a lag of the wrap): it is still linear in the
        law, but is no factor of the linear design, and the chain applies it after every
        multiplier, so that it acts on the whole exponent whatever the blocks' order.
    param_names : tuple of str
        Free parameters (calibrated with the law unless ``fixed``).
    bounds : dict
        ``(lower, upper)`` per parameter, in its units.
    probe : dict
        A typical magnitude per parameter, in its units (the signature's step).
    regressor : str
        What the effect leaves in the residual (the signature, in words).
    fixed : bool
        Hold the parameters at their values instead of fitting them.
    requires : tuple of str
        Effects the block refines (class attribute): a model needs their blocks too, and the
        diagnosis tries it once they are in.  A refining ``propagate`` block sets the step
        in place of the block it refines.
    geometric : bool
        Its parameters describe the robot's geometry and keep the law problem linear at any
        fixed value (class attribute): calibration profiles them out.
    """

    registry: ClassVar[BlockRegistry] = BLOCKS
    stages: ClassVar[tuple[str, ...]] = STAGES
    stage: ClassVar[str] = "exponent"
    also: ClassVar[tuple[str, ...]] = ()
    measurement_order: ClassVar[int] = 2
    whole_chain: ClassVar[bool] = False
    per_tendon: ClassVar[bool] = False
    multiplier: ClassVar[bool] = True
    geometric: ClassVar[bool] = False
    param_names: tuple[str, ...] = ()
    bounds: dict = field(default_factory=dict)
    probe: dict = field(default_factory=dict, compare=False, repr=False)
    fixed: bool = False

    def __init_subclass__(cls, **kwargs):
        super().__init_subclass__(**kwargs)
        wrong = [s for s in cls.also if s not in cls.stages or s == cls.stage]
        if wrong:
            raise TypeError(f"block {cls.name!r} also acts at {wrong}: each must be another of {', '.join(cls.stages)}")

    def acts_at(self, stage: str) -> bool:
        """Whether the block has a hook at ``stage``: its own, or one of :attr:`also`."""
        return stage == self.stage or stage in self.also

    def propagate_series(
        self,
        log_in: NDArray,
        phi: NDArray,
        n_pass: NDArray,
        ctx,
        values: dict,
        keep_chain: bool,
        start: NDArray | None = None,
    ) -> tuple[NDArray, NDArray | None] | None:
        """Optional, for a ``propagate`` block: every guide at once, when no other per-guide block acts.

        ``log_in`` (T, M) enters the first guide, ``phi`` (T, K, M) is each guide's exponent,
        column ``j`` passes ``n_pass[j]`` guides, and ``start`` (T, M), where a ``start`` block
        gives it, the share of each band a column restarts at; returns ``(final (T, M), chain
        (T, K, M) or None)`` as :func:`friction_models.kernels.play_series`.  The default, None, makes the
        chain call :meth:`propagate` guide by guide.  Whatever a block returns here must equal
        what its guide-by-guide steps give.
        """
        return None

    def param_tendon(self, param: str) -> int | None:
        """The 0-based tendon whose predictions alone parameter ``param`` moves, or None (every tendon's).

        A refit's finite-difference Jacobian perturbs parameters of different tendons in one
        evaluation (:mod:`tendon_id.zoo.snake.refit`).
        """
        return None

    def initial(self) -> dict[str, float]:
        """Starting values of the block's parameters."""
        return {p: float(getattr(self, p)) for p in self.param_names}

    def for_tendons(self, n_tendons: int) -> Block:
        """This block for a robot of ``n_tendons`` per set (default: itself; a block with a parameter per
        tendon resizes)."""
        return self

    def started_from(self, geometry) -> Block:
        """This block with the starting values the robot's measured sizes give (default: itself).

        ``geometry`` is a :class:`~tendon_id.geometry.RobotGeometry`; a block reads only what a
        user measures on the robot, never the simulator's truth (``alpha_0``, ``alpha_c``).
        """
        return self

    def neutral(self) -> dict[str, float]:
        """The parameters' values that switch the effect off: the class's defaults."""
        defaults = {f.name: f.default for f in fields(self)}
        return {p: float(defaults[p]) for p in self.param_names}

    def settings(self) -> dict:
        """Structural settings that are not fitted parameters (saved with the block)."""
        return {}

    def to_dict(self) -> dict:
        return {"block": self.name, "fixed": self.fixed, **self.settings(), **self.initial()}

    def probes(self) -> list[tuple[str, dict[str, float]]]:
        """``(label, values)`` pairs: the block at a typical magnitude, one per signature column.

        One column per free parameter (that parameter at its probe, the others neutral),
        or the block as it is when it has none.
        """
        if not self.param_names:
            return [(self.effect or self.name, {})]
        base = self.initial()
        return [(f"{self.effect or self.name}:{p}", {**base, p: float(self.probe[p])}) for p in self.param_names]

    def signature(
        self, model, inputs, A: NDArray, B: NDArray, values: dict, base: NDArray | None = None
    ) -> dict[str, NDArray]:
        """The block's signature regressors: what adding it changes in the terminal reading [N].

        ``T_hat(base + block at a probe) - T_hat(base)``, per column of :meth:`probes`, with
        the base law ``(A, B)`` and block values ``values``: to first order, the residual the
        effect leaves in a model that lacks it, up to its magnitude.

        Parameters
        ----------
        model : CapstanModel
            The base model (without this block).
        inputs : TransmissionInputs
        A, B : ndarray, shape (G, n)
            The base's law, for ``n`` tendons per set.
        values : dict
            The base's block parameters.
        base : ndarray, shape (T, n), optional
            The base's terminal reading with that law, if already computed [N].

        Returns
        -------
        dict of str to ndarray, shape (T, n)
        """
        block = self.for_tendons(inputs.n_tendons)
        augmented = model.with_blocks(block)
        if base is None:
            base = model.terminal_reading(inputs, A, B, values)
        out = {}
        for label, probe in block.probes():
            out[label] = augmented.terminal_reading(inputs, A, B, {**values, block.name: probe}) - base
        return out

    @classmethod
    def localise(cls, model, inputs, A, B, values, residual: NDArray) -> Block:
        """The candidate to try for a base model whose terminal residual is ``residual`` [N].

        Default: the block with neutral settings.  A block whose effect sits somewhere
        (a worn guide) overrides this to say where.
        """
        return cls()
