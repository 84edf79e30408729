"""What the neural models of the zoo share: the device they train on and their weights on disk.

Weights are stored as one safetensors blob inside the model's ``arrays.npz`` (:doc:`/guide/zoo`:
JSON plus npz, never pickle), so a learned model saves through the same
:meth:`~tendon_id.zoo.base.TransmissionModel.save` as an analytic one.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import torch
from safetensors.numpy import load, save

from tendon_id.errors import ConfigError

#: Key of the weights blob in ``arrays.npz``.
WEIGHTS_KEY = "weights_safetensors"


def resolve_device(device: str, *, float64: bool = False) -> torch.device:
    """``"auto"``: CUDA when present, else CPU.

    Raises
    ------
    ConfigError
        For a device string torch does not know, or, with ``float64=True`` (PG-CHTC normalises
        its inputs and sums its chain in float64), a device without float64 such as Apple's MPS.
    """
    if device == "auto":
        return torch.device("cuda" if torch.cuda.is_available() else "cpu")
    try:
        dev = torch.device(device)
    except (RuntimeError, TypeError):
        raise ConfigError(f"device must be 'auto', 'cpu' or 'cuda[:i]'; got {device!r}") from None
    if dev.type == "cuda" and not torch.cuda.is_available():
        raise ConfigError(f"device {device!r} is not available here (this torch sees no CUDA GPU); use 'cpu' or 'auto'")
    if float64 and dev.type not in ("cpu", "cuda"):
        raise ConfigError(
            f"PG-CHTC runs on 'cpu' or 'cuda' (it needs float64 for its inputs and chain, which MPS lacks); "
            f"got {device!r}"
        )
    return dev


def weights_array(module: torch.nn.Module) -> dict[str, np.ndarray]:
    """``{WEIGHTS_KEY: bytes}``: a module's state dict as a safetensors blob, for ``arrays.npz``."""
    weights = {k: v.detach().cpu().numpy() for k, v in module.state_dict().items()}
    return {WEIGHTS_KEY: np.frombuffer(save(weights), dtype=np.uint8)}


def load_weights(build: Callable[[], torch.nn.Module], arrays: dict[str, np.ndarray]) -> torch.nn.Module:
    """The module ``build()`` makes, with the weights of the blob written by :func:`weights_array`; in eval mode.

    The module is first built on torch's ``meta`` device, which allocates nothing, and its shapes
    are checked against the blob's: a configuration (``model.json``) that asks for other sizes
    than the weights hold is refused before any memory is taken, and weights with NaN or inf are
    refused too (a network with them answers NaN).

    Raises
    ------
    ConfigError
        Naming the first tensor whose shape differs, that is missing or extra, or that is not finite.
    """
    weights = load(arrays[WEIGHTS_KEY].tobytes())
    with torch.device("meta"):
        expected = {k: tuple(v.shape) for k, v in build().state_dict().items()}
    for k in sorted(set(expected) | set(weights)):
        if k not in weights or k not in expected:
            where = "the weights lack" if k not in weights else "the configuration has no"
            raise ConfigError(f"{where} tensor {k!r}: the configuration and the weights are of two networks")
        if tuple(weights[k].shape) != expected[k]:
            raise ConfigError(
                f"tensor {k!r} is {expected[k]} in the configuration but {tuple(weights[k].shape)} in the weights"
            )
        if weights[k].dtype.kind == "f" and not np.all(np.isfinite(weights[k])):
            raise ConfigError(f"tensor {k!r} of the weights holds NaN or inf")
    module = build()
    module.load_state_dict({k: torch.as_tensor(v) for k, v in weights.items()})
    return module.eval()
