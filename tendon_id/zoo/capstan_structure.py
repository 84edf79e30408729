"""A capstan model's structure and forward model: its blocks, its free parameters, the chain it runs.

:class:`CapstanStructure` is the part of :class:`~tendon_id.zoo.capstan.CapstanModel` that
needs no fitted state: which blocks the model has (every one has a routing wrap,
:class:`~tendon_id.zoo.blocks.geometric.RoutingWrap`), which of their parameters are calibrated
with the law, whether the terminal log-tension is linear in the law, and the forward model of
:mod:`tendon_id.zoo.chain` for a given law and block parameters.  The estimator API (fit,
predict, save) is :class:`~tendon_id.zoo.capstan.CapstanModel`'s.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from tendon_id.checks import check_choice, check_count, check_positive
from tendon_id.robot_file import resolve_robot
from tendon_id.zoo.blocks import Block, HookContext, RoutingWrap, as_block, compose
from tendon_id.zoo.chain import ExponentTerms, apply_sensor, exponent, exponent_terms, propagate_chain
from tendon_id.zoo.inputs import TransmissionInputs

MU_LAWS = ("affine-cosine", "constant")
TYINGS = ("tied", "per-guide")
#: Stages at which a tendon-independent block keeps ``ln T_N`` linear in the law.
LINEAR_STAGES = ("routing", "exponent")


class CapstanStructure:
    """Mixin of :class:`~tendon_id.zoo.capstan.CapstanModel`: its blocks and forward model (see the module docstring).

    Reads the settings ``mu_law``, ``blocks``, ``tying``, ``n_starts``, ``maxeval`` and
    ``warmup_s``, and ``geometry_`` once fitted.
    """

    @classmethod
    def general(cls) -> type:
        """The general capstan model class (what :meth:`with_blocks` and :meth:`smooth_part` build)."""
        raise NotImplementedError

    # ---- structure -----------------------------------------------------------
    def check_settings(self) -> None:
        self._validated()
        check_positive("xtol_rel", self.xtol_rel)  # NaN would stop nlopt at once, with no fit
        if self.robot is not None:
            resolve_robot(self.robot)  # a robot table or file that is no robot: refused before any data

    def _validated(self) -> tuple[Block, ...]:
        check_choice("mu_law", self.mu_law, MU_LAWS, what="friction law")
        check_choice("tying", self.tying, TYINGS)
        check_count("n_starts", self.n_starts, 1)
        check_count("maxeval", self.maxeval, 10)
        check_positive("warmup_s", self.warmup_s, "s", allow_zero=True)
        blocks = compose(self.blocks)
        # Every capstan model has a routing wrap (paper Eq. (3)'s alpha_0), fitted unless its
        # blocks hold one of their own.
        return blocks if any(b.stage == "routing" for b in blocks) else blocks + (RoutingWrap(),)

    @property
    def block_objects(self) -> tuple[Block, ...]:
        """The blocks as objects (``blocks`` may hold names), the routing wrap included.

        Once fitted, their starting values are those of the robot's measured sizes
        (:meth:`Block.started_from`), as in the fit.
        """
        blocks = self._validated()
        geometry = getattr(self, "geometry_", None)
        return blocks if geometry is None else tuple(b.started_from(geometry) for b in blocks)

    def started_from(self, geometry):
        """An unfitted copy whose blocks start from what ``geometry``'s measured sizes give (a fit's structure)."""
        model = type(self)(**self.get_params())
        # The blocks as given, not as a previous fit started them.
        model.blocks = tuple(b.started_from(geometry) for b in self._validated())
        return model

    def with_blocks(self, *extra: Block | str):
        """An unfitted copy of this model with ``extra`` blocks added (the diagnosis uses this)."""
        params = {**self.get_params(), "mu_law": self.mu_law}
        params["blocks"] = tuple(self.block_objects) + tuple(as_block(b) for b in extra)
        return self.general()(**params)

    def smooth_part(self):
        """An unfitted model of this one's law and tendon-independent routing and exponent blocks: its part
        linear in the law."""
        blocks = [b for b in self.block_objects if b.stage in LINEAR_STAGES and not b.per_tendon and b.multiplier]
        return self.general()(mu_law=self.mu_law, blocks=blocks, tying=self.tying)

    def free_parameters(self) -> list[tuple[str, str, tuple[float, float], float]]:
        """Block parameters calibrated with the law: ``(block, param, bounds, initial)``."""
        out = []
        for b in self.block_objects:
            if b.fixed:
                continue
            for p, v in b.initial().items():
                out.append((b.name, p, tuple(b.bounds[p]), float(v)))
        return out

    def geometric_parameters(self) -> list[tuple[str, str, tuple[float, float], float]]:
        """The free parameters of the geometric blocks (clearance, routing wrap): :meth:`free_parameters`' subset."""
        geometric = {b.name for b in self.block_objects if b.geometric}
        return [f for f in self.free_parameters() if f[0] in geometric]

    @property
    def is_smooth(self) -> bool:
        """True when ``ln T_N`` is linear in the law at any fixed geometry.

        Only tendon-independent routing and exponent blocks, and no free parameter but geometric
        ones (which calibration profiles out: :mod:`tendon_id.calibration.law_geometry`).
        """
        nonlinear = any(b.stage not in LINEAR_STAGES or b.per_tendon or not b.multiplier for b in self.block_objects)
        return not nonlinear and len(self.free_parameters()) == len(self.geometric_parameters())

    # ---- forward model (tendon_id.zoo.chain) ------------------------------------------
    def block_params(self, overrides: dict | None = None) -> dict[str, dict[str, float]]:
        """Every block's parameters ``{block: {param: value}}``: the blocks' own values, updated by ``overrides``.

        This is the ``values`` argument of :meth:`exponent`, :meth:`propagate` and
        :meth:`terminal_reading`; a fitted model's are ``block_params_``.
        """
        vals = {b.name: b.initial() for b in self.block_objects}
        for name, d in (overrides or {}).items():
            vals.setdefault(name, {}).update(d)
        return vals

    def backbone(self, inputs: TransmissionInputs, values: dict | None = None) -> NDArray:
        """The backbone wrap with this model's routing wrap, paper Eq. (3), shape (T, N-1) [rad]."""
        values = self.block_params() if values is None else values
        ctx = HookContext(inputs, np.array([inputs.n_modules - 1]), np.arange(inputs.n_tendons))
        alpha = inputs.bend_wrap
        for b in self.block_objects:
            if b.stage == "routing":
                alpha = b.routing(alpha, ctx, values.get(b.name, {}))
        return alpha

    def exponent_multiplier(self, inputs: TransmissionInputs, values: dict | None = None) -> NDArray:
        """Product of the tendon-independent exponent blocks' factors at the backbone wrap, shape (T, N-1, 1).

        The linear design of :class:`~tendon_id.calibration.problem.LawProblem` uses it; per-tendon blocks
        (wraps, sliding speeds) and filters over time (:attr:`Block.multiplier`) count as 1 there.
        """
        values = self.block_params() if values is None else values
        wrap = self.backbone(inputs, values)
        ctx = HookContext(
            inputs, np.array([inputs.n_modules - 1]), np.arange(inputs.n_tendons), alpha=wrap[:, :, None, None]
        )
        m = np.ones(wrap.shape + (1, 1))
        for b in self.block_objects:
            if b.stage == "exponent" and not b.per_tendon and b.multiplier:
                m = b.exponent(m, ctx, values.get(b.name, {}))
        return m[..., 0]

    def exponent_terms(
        self,
        inputs: TransmissionInputs,
        values: dict | None = None,
        sets: NDArray | None = None,
        tendons: NDArray | None = None,
    ) -> ExponentTerms:
        """The law-free part of the exponent (wrap, routing and exponent blocks), reusable while the law changes."""
        return exponent_terms(self.block_objects, inputs, *self._chain_defaults(inputs, values, sets, tendons))

    def _chain_defaults(self, inputs, values, sets, tendons) -> tuple[dict, NDArray, NDArray]:
        """``values``, ``sets`` and ``tendons`` with their defaults: the blocks' values, every set, every tendon."""
        values = self.block_params() if values is None else values
        sets = np.arange(inputs.n_modules) if sets is None else np.asarray(sets)
        tendons = np.arange(inputs.n_tendons) if tendons is None else np.asarray(tendons)
        return values, sets, tendons

    def exponent(self, inputs: TransmissionInputs, A: NDArray, B: NDArray, values: dict | None = None) -> NDArray:
        """Capstan exponent ``phi[t, k, j, i]`` (paper Eq. (5) with the blocks), shape (T, N-1, N|1, m).

        ``A``, ``B`` have shape (G, m) for ``m`` tendons; the constant law uses ``B`` as mu.
        The set axis has length 1 unless a block makes the exponent depend on the set.
        """
        return exponent(self.mu_law, self.exponent_terms(inputs, values, tendons=np.arange(A.shape[1])), A, B)

    def propagate(
        self,
        inputs: TransmissionInputs,
        A: NDArray,
        B: NDArray,
        values: dict | None = None,
        *,
        sets: NDArray | None = None,
        tendons: NDArray | None = None,
        keep_chain: bool = True,
        terms: ExponentTerms | None = None,
    ) -> NDArray:
        """Propagate ``ln T`` through the guides (paper Algorithm 1 with analytic ratios).

        Parameters
        ----------
        inputs : TransmissionInputs
        A, B : ndarray, shape (G, m)
            Law per guide (G = 1 tied) for the ``m`` tendons in ``tendons``.
        values : dict, optional
            Block parameters.
        sets : ndarray of int, optional
            0-based set indices to propagate (default all).
        tendons : ndarray of int, optional
            0-based tendon indices (default all three).
        keep_chain : bool
            Return the whole chain ``ln T[k, j, i]``, shape (T, N, S, m) with NaN
            off the path; else only the joint sides ``ln T[j, j, i]``, shape (T, S, m).
        terms : ExponentTerms, optional
            Precomputed :meth:`exponent_terms` for these sets and tendons.
        """
        values, sets, tendons = self._chain_defaults(inputs, values, sets, tendons)
        return propagate_chain(
            self.block_objects, self.mu_law, inputs, A, B, values, sets, tendons, keep_chain=keep_chain, terms=terms
        )

    def terminal_reading(
        self,
        inputs: TransmissionInputs,
        A: NDArray,
        B: NDArray,
        values: dict | None = None,
        tendons: NDArray | None = None,
        terms: ExponentTerms | None = None,
    ) -> NDArray:
        """Predicted terminal load-cell reading [N], shape (T, m) (the sensor blocks applied)."""
        joint_side = self.terminal_tension(inputs, A, B, values, tendons, terms)
        return self.sensor_reading(inputs, joint_side, values, tendons)

    def terminal_tension(
        self,
        inputs: TransmissionInputs,
        A: NDArray,
        B: NDArray,
        values: dict | None = None,
        tendons: NDArray | None = None,
        terms: ExponentTerms | None = None,
    ) -> NDArray:
        """Predicted joint-side tension of the last set ``T[N, N, i]`` [N], shape (T, m), before its load cell."""
        values, sets, tendons = self._chain_defaults(inputs, values, np.array([inputs.n_modules - 1]), tendons)
        log_t = self.propagate(inputs, A, B, values, sets=sets, tendons=tendons, keep_chain=False, terms=terms)
        return np.exp(log_t[:, 0])

    def sensor_reading(
        self, inputs: TransmissionInputs, tension: NDArray, values: dict | None = None, tendons: NDArray | None = None
    ) -> NDArray:
        """The terminal load cell's reading [N], shape (T, m), of the joint-side ``tension`` [N] (the sensor blocks)."""
        values, sets, tendons = self._chain_defaults(inputs, values, np.array([inputs.n_modules - 1]), tendons)
        return apply_sensor(self.block_objects, tension, HookContext(inputs, sets, tendons), values)

    def sensor_only(self, block: str) -> bool:
        """Whether block ``block`` acts on the terminal reading alone (not the chain): its parameters leave
        :meth:`terminal_tension` as it is."""
        return all(b.stage == "sensor" and not b.also for b in self.block_objects if b.name == block)
