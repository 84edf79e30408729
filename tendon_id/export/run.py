"""Run an exported model from Python, with ``streamer()``'s interface: ``step(angles, actuator)``, ``reset()``.

:class:`OnnxStep` runs ``model.onnx`` in onnxruntime and :class:`CStep` compiles the exported
C source into a shared library and calls it through ctypes, each carrying the step's state
between calls.  They are how the tests check an export against the streamer frame by frame,
how the latency benchmark times it, and a starting point for a deployment in Python.
"""

from __future__ import annotations

import ctypes
import json
import os
import shutil
import subprocess
import tempfile
import weakref
from pathlib import Path

import numpy as np

from tendon_id.errors import ConfigError, TendonIdError

__all__ = ["CStep", "CompilerUnavailable", "OnnxStep", "find_compiler", "read_manifest"]

MANIFEST = "export.json"


class CompilerUnavailable(TendonIdError):
    """No C compiler here (set ``CC``, or install gcc or clang)."""


def read_manifest(folder: str | os.PathLike, fmt: str | None = None) -> dict:
    """``export.json`` of an export folder, checked to be of format ``fmt`` (any if None)."""
    path = Path(folder) / MANIFEST
    if not path.is_file():
        raise ConfigError(f"{folder}: no {MANIFEST} here; is this a folder written by 'tendon-id export'?")
    try:
        manifest = json.loads(path.read_text())
    except json.JSONDecodeError as exc:
        raise ConfigError(f"{path}: not valid JSON ({exc})") from None
    if fmt is not None and manifest.get("format") != fmt:
        raise ConfigError(f"{path}: an export to {manifest.get('format')!r}, not {fmt!r}")
    return manifest


def _frame(angles, actuator, n: int, m: int) -> tuple[np.ndarray, np.ndarray]:
    angles = np.ascontiguousarray(angles, dtype=np.float64)
    actuator = np.ascontiguousarray(actuator, dtype=np.float64)
    if angles.shape != (n, 2) or actuator.shape != (n, m):
        raise ValueError(f"expected angles ({n}, 2) and actuator ({n}, {m}); got {angles.shape} and {actuator.shape}")
    return angles, actuator


class OnnxStep:
    """An exported ``model.onnx`` in onnxruntime, one frame per :meth:`step`.

    Parameters
    ----------
    folder : path-like
        A folder written by ``tendon-id export --format onnx``.
    threads : int
        onnxruntime's threads within an operator (default 1: a frame's operators are small, and
        one thread leaves the others to the rest of the controller).
    """

    def __init__(self, folder: str | os.PathLike, threads: int = 1):
        import onnxruntime

        self.manifest = read_manifest(folder, "onnx")
        options = onnxruntime.SessionOptions()
        options.intra_op_num_threads = threads
        options.inter_op_num_threads = 1
        self.session = onnxruntime.InferenceSession(
            str(Path(folder) / "model.onnx"), options, providers=["CPUExecutionProvider"]
        )
        self.n, self.m = self.manifest["n_modules"], self.manifest["n_tendons"]
        state = self.manifest["state"]
        self.state_names = [e["name"] for e in state]
        self.initial = {e["name"]: np.full(e["shape"], e["initial"], dtype=e["dtype"]) for e in state}
        self.outputs = ["tensions"] + [f"{name}_out" for name in self.state_names]
        self.reset()

    def reset(self) -> None:
        """Start a new trajectory: every state input at its initial value."""
        self.state = {k: v.copy() for k, v in self.initial.items()}

    def step(self, angles: np.ndarray, actuator: np.ndarray) -> np.ndarray:
        """One frame: angles (N, 2) [rad], actuator-side tensions (N, m) [N] in; joint-side tensions (N, m) [N] out."""
        angles, actuator = _frame(angles, actuator, self.n, self.m)
        out = self.session.run(self.outputs, {"angles": angles, "actuator": actuator, **self.state})
        self.state = dict(zip(self.state_names, out[1:]))
        return out[0]


def find_compiler() -> str | None:
    """The C compiler: ``CC`` if set, else the first of ``cc``, ``gcc``, ``clang`` on the ``PATH``; None if none."""
    cc = os.environ.get("CC")
    if cc:
        return shutil.which(cc) or (cc if Path(cc).exists() else None)
    return next((p for p in map(shutil.which, ("cc", "gcc", "clang")) if p), None)


class CStep:
    """An exported C step, compiled to a shared library and called through ctypes, one frame per :meth:`step`.

    Parameters
    ----------
    folder : path-like
        A folder written by ``tendon-id export --format c``.
    flags : sequence of str
        Compiler flags (default ``-O2``, as the export's build line says).

    Raises
    ------
    CompilerUnavailable
        If no C compiler is found.
    TendonIdError
        If the source does not compile (with the compiler's last lines).
    """

    def __init__(self, folder: str | os.PathLike, flags: tuple[str, ...] = ("-O2",)):
        self.manifest = read_manifest(folder, "c")
        cc = find_compiler()
        if cc is None:
            raise CompilerUnavailable("no C compiler found (set CC, or install gcc or clang)")
        c = self.manifest["c"]
        prefix = c["prefix"]
        self._tmp = tempfile.mkdtemp(prefix="tendon-id-export-")
        weakref.finalize(self, shutil.rmtree, self._tmp, True)
        lib = Path(self._tmp) / f"lib{prefix}.so"
        cmd = [cc, *flags, "-shared", "-fPIC", "-o", str(lib), str(Path(folder) / c["source"]), "-lm"]
        run = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
        if run.returncode != 0:
            raise TendonIdError(f"compiling {c['source']} failed: {' '.join(cmd)}: {run.stderr.strip()[-600:]}")
        self.lib = ctypes.CDLL(str(lib))
        vp = ctypes.c_void_p
        self._step = getattr(self.lib, f"{prefix}_step")
        self._step.argtypes, self._step.restype = [vp, vp, vp, vp], ctypes.c_int
        self._reset = getattr(self.lib, f"{prefix}_reset")
        self._reset.argtypes = [vp]
        size = getattr(self.lib, f"{prefix}_state_size")
        size.restype = ctypes.c_size_t
        self.n, self.m = self.manifest["n_modules"], self.manifest["n_tendons"]
        self.state = np.zeros(size() // 8 + 1, dtype=np.float64)  # 8-byte aligned, as the struct's doubles need
        self._state_ptr = self.state.ctypes.data
        self._out = np.empty((self.n, self.m), dtype=np.float64)
        init = getattr(self.lib, f"{prefix}_init")
        init.argtypes = [vp]
        init(self._state_ptr)

    def reset(self) -> None:
        """Start a new trajectory."""
        self._reset(self._state_ptr)

    def step(self, angles: np.ndarray, actuator: np.ndarray) -> np.ndarray:
        """One frame: angles (N, 2) [rad], actuator-side tensions (N, m) [N] in; joint-side tensions (N, m) [N] out.

        Raises ValueError, as the C step refuses it, for a non-finite input or a tension that is not > 0.
        """
        angles, actuator = _frame(angles, actuator, self.n, self.m)
        if self._step(self._state_ptr, angles.ctypes.data, actuator.ctypes.data, self._out.ctypes.data):
            raise ValueError("the exported step refused the frame: an input is not finite or a tension is not > 0")
        return self._out.copy()
