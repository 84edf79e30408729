"""What the neural models of the zoo share: the device they train on and their weights on disk.

Weights are stored as one safetensors blob inside the model's ``arrays.npz`` (:doc:`/guide/zoo`:
JSON plus npz, never pickle), so a learned model saves through the same
:meth:`~tendon_id.zoo.base.TransmissionModel.save` as an analytic one.
"""

from __future__ import annotations

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


def load_weights(module: torch.nn.Module, arrays: dict[str, np.ndarray]) -> torch.nn.Module:
    """Load the blob written by :func:`weights_array` into ``module``; returns it in eval mode."""
    weights = load(arrays[WEIGHTS_KEY].tobytes())
    module.load_state_dict({k: torch.as_tensor(v) for k, v in weights.items()})
    return module.eval()
