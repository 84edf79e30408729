"""The exported step's interface, one description for every format: its inputs, outputs and state.

A step reads one frame, ``angles`` (N, 2) [rad] and ``actuator`` (N, m) [N], with the state
the previous step left, and returns ``tensions`` (N, m) [N], the joint-side estimates
``T_hat[j, j, i]`` of ``streamer().step``, with the new state.  A trajectory starts from the
initial state (every entry its ``initial`` value), as ``streamer().reset()`` does.
"""

from __future__ import annotations

from tendon_id.export.spec import CapstanSpec, CascadeSpec

__all__ = ["frame_inputs", "frame_outputs", "state_entries"]


def frame_inputs(spec: CapstanSpec | CascadeSpec) -> list[dict]:
    n, m = spec.n_modules, spec.n_tendons
    return [
        {
            "name": "angles",
            "shape": [n, 2],
            "dtype": "float64",
            "units": "rad",
            "doc": "joint angles theta_k (x, y) of joints 1..N",
        },
        {
            "name": "actuator",
            "shape": [n, m],
            "dtype": "float64",
            "units": "N",
            "doc": "actuator-side tensions T[1, j, i] of sets 1..N, tendons 1..m (> 0)",
        },
    ]


def frame_outputs(spec: CapstanSpec | CascadeSpec) -> list[dict]:
    n, m = spec.n_modules, spec.n_tendons
    return [
        {
            "name": "tensions",
            "shape": [n, m],
            "dtype": "float64",
            "units": "N",
            "doc": "joint-side estimates T_hat[j, j, i]: set j at its own joint (set 1 is its actuator reading)",
        }
    ]


def state_entries(spec: CapstanSpec | CascadeSpec) -> list[dict]:
    """The state: each entry an input of the step, returned updated as ``NAME_out``; ``initial`` starts a trajectory."""
    out = [
        {
            "name": "n_seen",
            "shape": [1],
            "dtype": "int64",
            "units": "frames",
            "initial": 0,
            "doc": "frames seen since the trajectory started, saturating at "
            + (f"the window ({spec.window})" if isinstance(spec, CascadeSpec) else "1"),
        }
    ]
    if isinstance(spec, CapstanSpec):
        if spec.hysteresis:
            out.append(
                {
                    "name": "play_y",
                    "shape": [spec.n_modules - 1, spec.n_modules, spec.n_tendons],
                    "dtype": "float64",
                    "units": "ln N",
                    "initial": 0.0,
                    "doc": "play operator output ln T leaving guide g (0-based) of set s > g, tendon i; "
                    "entries s <= g unused",
                }
            )
        return out
    if spec.residual:
        shape = [spec.n_layers, spec.n_streams, spec.n_heads, spec.window, spec.d_head]
        for name, what in (("keys", "keys"), ("values", "values")):
            out.append(
                {
                    "name": name,
                    "shape": shape,
                    "dtype": "float32",
                    "units": "-",
                    "initial": 0.0,
                    "doc": f"attention {what} of the last {spec.window} frames, per layer, stream (guide g's "
                    f"N - 1 - g sets, guide after guide), head, frame (oldest first), channel",
                }
            )
    return out
