"""Streaming PG-CHTC through a small C kernel, for CPU inference within a control period.

:class:`NativeStreamingCascade` runs the same frame as
:class:`learners.cascade.StreamingCascade` (paper Algorithm 1: per guide, ``f_theta``
times ``1 + r_TR`` from ring caches of the last ``h`` frames) in ``streaming_kernel.c``,
which is compiled once per machine with the C compiler found at run time and cached.
Where no compiler works, :func:`load_kernel` raises :class:`KernelUnavailable` and the
caller falls back to the torch engine, which computes the same thing more slowly.

Why a kernel: a frame is hundreds of small matrix products (eleven sequential guide steps
of 11..1 rows for N = 12), so in torch their dispatch costs as much as their arithmetic.

Environment
-----------
``TENDON_ID_NATIVE=0``
    Never build or use the kernel.
``TENDON_ID_CACHE``
    Where the compiled kernel is kept, beside the built datasets (default ``~/.cache/tendon-id``).
``CC``
    The C compiler (default: the first of ``cc``, ``gcc``, ``clang`` on the ``PATH``).
"""

from __future__ import annotations

import ctypes
import hashlib
import os
import platform
import shutil
import subprocess
import sys
import tempfile
import threading
import time
import weakref
from pathlib import Path

import numpy as np
import torch

from learners.cascade import LOG_RATIO_BOUND, Cascade
from learners.streaming_pack import WEIGHT_FORMATS, as_f32, half_copy, pack_unit
from learners.thread_choice import ThreadChooser
from learners.unit import n_features

SOURCE = Path(__file__).with_name("streaming_kernel.c")
HEADER = SOURCE.with_name("streaming_gemm.h")  # included by SOURCE: its matrix products
#: The kernel's configuration vector, in the order of its ``C_*`` enum.  ``n_tendons`` came last, so the
#: others kept their places; a kernel built from an older source is rebuilt anyway (the cache is keyed by
#: the source's hash) and one that does not match is refused (``pgchtc_cfg_len``).
CONFIG_FIELDS = (
    "n_sets",
    "n_guides",
    "tied",
    "n_hidden",
    "hidden0",
    "hidden1",
    "hidden2",
    "hidden3",
    "residual",
    "d_model",
    "n_heads",
    "window",
    "d_ff",
    "n_layers",
    "n_tendons",
)
MAX_HIDDEN = 4
_FLAG_SETS = (
    ("-O3", "-march=native", "-std=gnu11", "-pthread"),
    ("-O3", "-std=gnu11", "-pthread"),
)  # native SIMD first, portable second

_lock = threading.Lock()
_loaded: ctypes.CDLL | None = None
_failure: str | None = None


class KernelUnavailable(RuntimeError):
    """The C kernel cannot be built or loaded here; the reason is the message."""


def cache_dir() -> Path:
    """Where compiled kernels are kept: the folder of the dataset cache (``tendon_id.datasets``)."""
    return Path(os.environ.get("TENDON_ID_CACHE") or Path.home() / ".cache" / "tendon-id")


def disabled() -> bool:
    """Whether the user switched the kernel off (``TENDON_ID_NATIVE=0``)."""
    return os.environ.get("TENDON_ID_NATIVE", "1").strip().lower() in ("0", "false", "no", "off")


def _compiler() -> str | None:
    cc = os.environ.get("CC")
    if cc:
        return shutil.which(cc) or (cc if Path(cc).exists() else None)
    return next((p for p in map(shutil.which, ("cc", "gcc", "clang")) if p), None)


def _cpu_signature() -> str:
    """What ``-march=native`` compiles for: a library built on one CPU may not run on another."""
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith(("flags", "Features")):
                    return line
    except OSError:
        pass
    return platform.processor() + platform.machine()


def _build(cc: str, target: Path) -> None:
    target.parent.mkdir(parents=True, exist_ok=True)
    errors = []
    for flags in _FLAG_SETS:
        fd, tmp = tempfile.mkstemp(prefix=".kernel-", suffix=".so", dir=target.parent)
        os.close(fd)
        cmd = [cc, *flags, "-shared", "-fPIC", "-o", tmp, str(SOURCE), "-lm"]
        try:
            run = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
            if run.returncode == 0:
                os.replace(tmp, target)  # atomic: a concurrent process sees the old file or the whole new one
                return
            errors.append(f"{' '.join(cmd)}: {run.stderr.strip()[-400:]}")
        finally:
            if os.path.exists(tmp):
                os.unlink(tmp)
    raise KernelUnavailable("compiling the streaming kernel failed:\n" + "\n".join(errors))


def load_kernel() -> ctypes.CDLL:
    """The compiled kernel, built on first use (about a second) and cached per source, compiler and CPU.

    Raises
    ------
    KernelUnavailable
        With the reason, if it is disabled (``TENDON_ID_NATIVE=0``), no C compiler is found,
        or compiling or loading fails.  The outcome is remembered for the process.
    """
    global _loaded, _failure
    with _lock:
        if _loaded is not None:
            return _loaded
        if _failure is not None:
            raise KernelUnavailable(_failure)
        try:
            _loaded = _load()
            return _loaded
        except KernelUnavailable as e:
            _failure = str(e)
            raise


def _load() -> ctypes.CDLL:
    if disabled():
        raise KernelUnavailable("disabled by TENDON_ID_NATIVE=0")
    if sys.platform == "win32":
        raise KernelUnavailable("the streaming kernel is built with a Unix C compiler; not on Windows")
    cc = _compiler()
    if cc is None:
        raise KernelUnavailable("no C compiler found (set CC, or install gcc or clang)")
    key = hashlib.sha256(
        SOURCE.read_bytes() + HEADER.read_bytes() + cc.encode() + repr(_FLAG_SETS).encode() + _cpu_signature().encode()
    ).hexdigest()[:16]
    target = cache_dir() / f"streaming_kernel-{key}.so"
    if not target.exists():
        _build(cc, target)
    try:
        lib = ctypes.CDLL(str(target))
    except OSError as e:
        raise KernelUnavailable(f"loading {target} failed: {e}") from e
    vp, i32, f32 = ctypes.c_void_p, ctypes.c_int, ctypes.c_float
    lib.pgchtc_frame.argtypes = [vp, vp, vp, vp, f32, vp, vp, vp, i32, i32, vp, vp, i32, vp]
    lib.pgchtc_helper_new.argtypes = []
    lib.pgchtc_helper_new.restype = vp
    lib.pgchtc_helper_free.argtypes = [vp]
    lib.pgchtc_frame.restype = i32
    lib.pgchtc_unit_floats.argtypes = [vp]
    lib.pgchtc_unit_floats.restype = ctypes.c_long
    lib.pgchtc_cache_floats.argtypes = [vp, i32]
    lib.pgchtc_cache_floats.restype = ctypes.c_long
    lib.pgchtc_erf.argtypes = [vp, vp, i32]
    lib.pgchtc_half_to_float.argtypes = [vp, vp, i32]
    lib.pgchtc_panel_width.restype = i32
    if lib.pgchtc_cfg_len() != len(CONFIG_FIELDS):
        raise KernelUnavailable(f"{target} does not match this version of tendon-id")
    return lib


def kernel_status() -> tuple[bool, str]:
    """Whether the kernel is usable here, and if not, why."""
    try:
        load_kernel()
        return True, "ok"
    except KernelUnavailable as e:
        return False, str(e)


def available_cpus() -> int:
    """CPUs this process may run on (its affinity mask where the OS has one)."""
    try:
        return len(os.sched_getaffinity(0))
    except (AttributeError, OSError):
        return os.cpu_count() or 1


#: Multiply-adds per row of f_theta and of g_phi from which a helper thread pays for its start
#: and its 11 meetings per frame (N = 12).  Measured on 2 cores (AVX2): the paper preset (0.40 M
#: and 0.39 M) gains 1.3-1.9x; the fast preset (7 k and 17 k) loses, 0.31 ms on one thread
#: against 0.52 ms on two.
HELPER_THREAD_MIN_MACS = 100_000


def unit_macs(cfg, n_tendons: int = 3) -> tuple[int, int]:
    """Multiply-adds per row of ``f_theta`` and ``g_phi`` (0 without a residual), the Linear layers only.

    ``n_tendons`` (``n``) sets the units' input (``5 + n``) and output (``n``) widths.
    """
    n_in = n_features(n_tendons)
    widths = (n_in, *cfg.hidden, n_tendons)
    backbone = sum(a * b for a, b in zip(widths[:-1], widths[1:]))
    if not cfg.temporal_residual:
        return backbone, 0
    d, f = cfg.d_model, cfg.d_ff
    return backbone, n_in * d + cfg.n_layers * (3 * d * d + d * d + 2 * d * f) + n_tendons * d


def helper_thread_pays(cfg, n_tendons: int = 3) -> bool:
    """Whether computing g_phi on a helper thread beside f_theta is worth it for this unit size."""
    f, g = unit_macs(cfg, n_tendons)
    return min(f, g) >= HELPER_THREAD_MIN_MACS


def unsupported(cascade: Cascade) -> str | None:
    """Why the kernel cannot run this cascade, or None if it can."""
    p = next(cascade.parameters())
    if p.device.type != "cpu":
        return f"parameters on {p.device}, the kernel runs on the CPU"
    if p.dtype != torch.float32:
        return f"parameters in {p.dtype}, the kernel computes in float32"
    if len(cascade.cfg.hidden) > MAX_HIDDEN:
        return f"more than {MAX_HIDDEN} hidden layers in f_theta"
    return None


def _free_helper(lib: ctypes.CDLL, helper: int, pid: int) -> None:
    """End a helper thread, in the process that started it: a forked child has the handle but not the
    thread, and joining a thread it does not have could hang it."""
    if os.getpid() == pid:
        lib.pgchtc_helper_free(helper)


class NativeStreamingCascade:
    """Frame-by-frame inference in the C kernel: the work and the state of :class:`~learners.cascade.StreamingCascade`.

    The parameters are copied at construction (float32, BatchNorm folded); later changes
    to ``cascade`` are not seen.  The kernel runs on the calling thread and releases the GIL;
    with ``threads=2`` a helper thread computes ``g_phi`` beside ``f_theta`` during each frame,
    with the same result to the bit.

    Parameters
    ----------
    cascade : Cascade
        A float32 cascade on the CPU, in eval mode.
    n_sets : int
        ``N``, the number of tendon sets.
    threads : int or "auto", optional
        1, 2, or ``"auto"``: each frame on the count that has been faster lately
        (:class:`~learners.thread_choice.ThreadChooser`), since a helper gains only where a
        second core is free.  Default: ``"auto"`` where both parts of the unit are large enough
        to pay for the helper (:func:`helper_thread_pays`, true for the paper preset) and the
        process may use at least two CPUs, else 1.  The helper spins briefly, then sleeps, while
        it waits.  Where it cannot be started, frames run on one thread (``threads`` then reads 1).
    weights : {"float32", "float16"}, optional
        The precision the matrix products read their weights in.  ``"float32"`` (default) is
        the reference, the same frame as batch inference.  ``"float16"`` reads an IEEE
        half-precision copy of each weight matrix (half the memory traffic; biases, norms,
        activations and sums stay float32), faster where the weights do not fit a core's cache,
        at a measured cost in agreement (see the latency benchmark and the streaming guide).

    Raises
    ------
    KernelUnavailable
        If the kernel cannot be built here, or cannot run this cascade.
    """

    def __init__(self, cascade: Cascade, n_sets: int, threads: int | str | None = None, weights: str = "float32"):
        why = unsupported(cascade)
        if why:
            raise KernelUnavailable(why)
        if threads is None:
            threads = "auto" if helper_thread_pays(cascade.cfg, cascade.n_tendons) and available_cpus() >= 2 else 1
        if threads not in (1, 2, "auto"):
            raise ValueError(f"threads must be 1, 2 or 'auto', got {threads!r}")
        if weights not in WEIGHT_FORMATS:
            raise ValueError(f"weights must be one of {', '.join(WEIGHT_FORMATS)}, got {weights!r}")
        self.weights = weights
        self.chooser = ThreadChooser() if threads == "auto" else None
        self.threads = threads
        self.lib = load_kernel()
        # One helper thread for the engine's life (a thread start per frame cost about 40 us); it
        # sleeps in the kernel between frames, and ends when the engine is collected.
        self._helper = self._pid = self._finalizer = None
        self._wants_helper = threads != 1 and cascade.cfg.temporal_residual
        if self._wants_helper:
            self._start_helper()
        cfg = cascade.cfg
        hidden = list(cfg.hidden) + [0] * (MAX_HIDDEN - len(cfg.hidden))
        self.config = np.array(
            [
                n_sets,
                cascade.n_guides,
                int(cascade.tied),
                len(cfg.hidden),
                *hidden,
                int(cfg.temporal_residual),
                cfg.d_model,
                cfg.n_heads,
                cfg.window,
                cfg.d_ff,
                cfg.n_layers,
                cascade.n_tendons,
            ],
            dtype=np.int32,
        )
        self.n_sets, self.window, self.n_tendons = n_sets, cfg.window, cascade.n_tendons
        self.units = [pack_unit(u, self.lib.pgchtc_panel_width()) for u in cascade.units]
        expected = self.lib.pgchtc_unit_floats(self.config.ctypes.data)
        if any(u.size != expected for u in self.units):  # the packer and the kernel disagree on the layout
            raise KernelUnavailable(
                f"parameter layout mismatch: packed {self.units[0].size} floats, the kernel reads {expected}"
            )
        self.norm = np.concatenate([as_f32(cascade.feature_mean), as_f32(cascade.feature_std)]).astype(np.float64)
        self.caches = [
            np.zeros(max(1, self.lib.pgchtc_cache_floats(self.config.ctypes.data, g)), np.float32)
            for g in range(cascade.n_guides)
        ]
        ptrs = lambda arrays: (ctypes.c_void_p * max(1, len(arrays)))(*[a.ctypes.data for a in arrays])  # noqa: E731
        self._unit_ptrs, self._cache_ptrs = ptrs(self.units), ptrs(self.caches)
        self.half_units = [half_copy(u, i) for i, u in enumerate(self.units)] if weights == "float16" else []
        self._half_ptrs = ptrs(self.half_units) if self.half_units else None
        self._out = np.empty((n_sets, self.n_tendons), np.float64)
        # addresses of the arrays the engine keeps, taken once (each .ctypes costs about a microsecond)
        self._config_ptr, self._norm_ptr, self._out_ptr = (a.ctypes.data for a in (self.config, self.norm, self._out))
        self.reset()

    def _start_helper(self) -> None:
        self._helper, self._pid = self.lib.pgchtc_helper_new(), os.getpid()
        if self._helper:
            self._finalizer = weakref.finalize(self, _free_helper, self.lib, self._helper, self._pid)
        else:  # could not be started: every frame on one thread
            self.threads, self.chooser, self._wants_helper = 1, None, False

    def close(self) -> None:
        """End the helper thread now rather than when the engine is collected (a later frame starts another)."""
        if self._finalizer is not None:
            self._finalizer()
        self._helper = self._finalizer = None

    def reset(self) -> None:
        """Forget the history (call at the start of a trajectory)."""
        for c in self.caches:
            c.fill(0.0)
        self.n_seen = 0

    def step(self, sin_q: np.ndarray, alpha: np.ndarray, log_actuator: np.ndarray) -> np.ndarray:
        """Joint-side ``ln T_hat[j, j, :]`` of all sets for one frame, float64 of shape (N, n).

        Parameters
        ----------
        sin_q : array, shape (N-1, 4)
            ``sin`` of the adjacent joint angles of each guide.
        alpha : array, shape (N-1,)
            Backbone wrap of each guide [rad].
        log_actuator : array, shape (N, n)
            ``ln`` of the actuator-side tensions [ln N], ``n`` tendons per set.
        """
        n, n_t = self.n_sets, self.n_tendons
        sin_q = np.ascontiguousarray(sin_q, dtype=np.float64)
        alpha = np.ascontiguousarray(alpha, dtype=np.float64)
        log_actuator = np.ascontiguousarray(log_actuator, dtype=np.float64)
        if sin_q.shape != (n - 1, 4) or alpha.shape != (n - 1,) or log_actuator.shape != (n, n_t):
            raise ValueError(
                f"expected sin_q ({n - 1}, 4), alpha ({n - 1},), log_actuator ({n}, {n_t}); "
                f"got {sin_q.shape}, {alpha.shape}, {log_actuator.shape}"
            )
        if self._wants_helper and (self._helper is None or self._pid != os.getpid()):
            self._start_helper()  # after close(), or in a forked child, which has the handle but not the thread
        threads = self.chooser.next() if self.chooser is not None else self.threads
        start = time.perf_counter()
        rc = self.lib.pgchtc_frame(
            self._config_ptr,
            self._unit_ptrs,
            self._half_ptrs,
            self._norm_ptr,
            LOG_RATIO_BOUND,
            sin_q.ctypes.data,
            alpha.ctypes.data,
            log_actuator.ctypes.data,
            self.n_seen % self.window,
            min(self.n_seen, self.window - 1),
            self._cache_ptrs,
            self._out_ptr,
            threads,
            self._helper,
        )
        if self.chooser is not None and rc == 0:
            self.chooser.record(threads, time.perf_counter() - start)
        if rc == 1:
            raise MemoryError("the streaming kernel could not allocate its scratch memory")
        self.n_seen += 1
        return self._out.copy()
