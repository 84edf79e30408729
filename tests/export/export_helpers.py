"""Helpers of the export tests (a module of its own: ``conftest`` is a name every test folder's conftest takes)."""

import numpy as np

from tendon_id.export.run import CStep

#: The C export compiles as pedantic C99 without a warning.
STRICT = ("-O2", "-std=c99", "-Wall", "-Wextra", "-pedantic", "-Werror")


def strict_c(folder) -> CStep:
    """The exported C step of ``folder``, compiled with :data:`STRICT`."""
    return CStep(folder, flags=STRICT)


def stream_recording(stepper, angles, actuator, reset) -> np.ndarray:
    """Every frame through ``stepper`` (``step(angles, actuator)``, ``reset()``), reset where ``reset`` is True."""
    out = []
    for t in range(len(angles)):
        if reset[t]:
            stepper.reset()
        out.append(stepper.step(angles[t], actuator[t]))
    return np.stack(out)
