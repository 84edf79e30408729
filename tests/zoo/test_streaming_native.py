"""The C streaming kernel: the same frame as the torch engine, as exact as float32 allows, and a clean fallback."""

import numpy as np
import pytest
import torch

from learners import Cascade, CascadeInputs, preset
from learners import streaming_native as sn


@pytest.fixture(scope="module")
def kernel():
    ok, why = sn.kernel_status()
    if not ok:
        pytest.skip(f"no streaming kernel here: {why}")
    return sn.load_kernel()


def test_kernel_erf_is_float32_accurate(kernel):
    x = np.linspace(-6.0, 6.0, 200_001, dtype=np.float32)
    y = np.empty_like(x)
    kernel.pgchtc_erf(x.ctypes.data, y.ctypes.data, x.size)
    exact = torch.erf(torch.from_numpy(x).double()).numpy()
    assert np.max(np.abs(y - exact)) < 5e-7


def _random_cascade(n, tied, residual, seed=0, n_tendons=3):
    torch.manual_seed(seed)
    cfg = preset("tiny", temporal_residual=residual).unit
    cascade = Cascade(n - 1, cfg, tied=tied, n_tendons=n_tendons).eval()
    with torch.no_grad():
        for u in cascade.units:
            u.backbone.head.weight.mul_(0.3)  # ratios near 1, so that the chain does not amplify rounding
            for bn in (
                m for m in u.backbone.body if isinstance(m, torch.nn.BatchNorm1d)
            ):  # non-trivial folded BatchNorm
                bn.running_mean.uniform_(-0.2, 0.2)
                bn.running_var.uniform_(0.5, 2.0)
                bn.weight.uniform_(0.8, 1.2)
            if u.residual is not None:
                torch.nn.init.normal_(u.residual.head.weight, std=0.3)  # a residual that matters
                for layer in u.residual.layers:
                    torch.nn.init.normal_(layer.attn.lag_bias, std=1.0)  # lags distinguishable
        cascade.feature_mean.copy_(torch.tensor([0, 0, 0, 0, 0.9] + [150.0] * n_tendons))
        cascade.feature_std.copy_(torch.tensor([0.2, 0.2, 0.2, 0.2, 0.05] + [60.0] * n_tendons))
    return cascade


@pytest.mark.parametrize("threads", [1, 2])
@pytest.mark.parametrize("tied", [True, False])
@pytest.mark.parametrize("residual", [True, False])
@pytest.mark.parametrize("n_tendons", [3, 2, 4, 5])
def test_native_frames_equal_exact_arithmetic_over_many_windows(kernel, tied, residual, threads, n_tendons):
    """Against float64 batch inference of the same cascade, while the ring caches wrap four times; for the
    paper's three tendons a set and other counts (the kernel reads the count from its configuration)."""
    n, L = 5, 23  # tiny preset: window 5
    cascade = _random_cascade(n, tied, residual, n_tendons=n_tendons)
    g = torch.Generator().manual_seed(1)
    sin_q = 0.2 * torch.randn(1, L, n - 1, 4, generator=g)
    alpha = 0.05 + 0.3 * torch.rand(1, L, n - 1, generator=g)
    log_act = 5.0 + 0.3 * torch.randn(1, L, n, n_tendons, generator=g)
    c64 = Cascade(n - 1, cascade.cfg, tied=tied, n_tendons=n_tendons).double().eval()
    c64.load_state_dict(cascade.state_dict())
    with torch.no_grad():
        exact, _ = c64(
            CascadeInputs(sin_q.double(), alpha.double(), log_act.double(), torch.arange(L)[None]), torch.arange(n)
        )
    engine = sn.NativeStreamingCascade(cascade, n, threads=threads)
    out = np.stack([engine.step(sin_q[0, t].numpy(), alpha[0, t].numpy(), log_act[0, t].numpy()) for t in range(L)])
    np.testing.assert_allclose(out, exact[0].numpy(), rtol=0, atol=1e-6)  # measured 2.2e-7 to 5.2e-7
    assert np.ptp(out[:, -1] - log_act[0, :, -1].numpy()) > 0.01  # the chain did something frame to frame
    engine.reset()
    again = np.stack([engine.step(sin_q[0, t].numpy(), alpha[0, t].numpy(), log_act[0, t].numpy()) for t in range(7)])
    np.testing.assert_array_equal(again, out[:7])


@pytest.mark.parametrize("n_tendons", [3, 4])
@pytest.mark.parametrize("tied", [True, False])
def test_helper_thread_gives_the_same_bits(kernel, tied, n_tendons):
    """g_phi on a helper thread beside f_theta: the same arithmetic, so the same bits, frame after frame."""
    n, L = 6, 17
    cascade = _random_cascade(n, tied, True, seed=4, n_tendons=n_tendons)
    frames = _frames(n, L, seed=2, n_tendons=n_tendons)
    one, two = sn.NativeStreamingCascade(cascade, n, threads=1), sn.NativeStreamingCascade(cascade, n, threads=2)
    auto = sn.NativeStreamingCascade(cascade, n, threads="auto")  # switches between the two: still the same bits
    for f in frames:
        ref = one.step(*f)
        np.testing.assert_array_equal(two.step(*f), ref)
        np.testing.assert_array_equal(auto.step(*f), ref)
    with pytest.raises(ValueError, match="threads"):
        sn.NativeStreamingCascade(cascade, n, threads=3)


def test_native_step_rejects_wrong_shapes(kernel):
    engine = sn.NativeStreamingCascade(_random_cascade(4, True, True), 4)
    with pytest.raises(ValueError, match=r"sin_q \(3, 4\)"):
        engine.step(np.zeros((4, 4)), np.zeros(3), np.zeros((4, 3)))
    four = sn.NativeStreamingCascade(_random_cascade(4, True, True, n_tendons=4), 4)
    with pytest.raises(ValueError, match=r"log_actuator \(4, 4\)"):
        four.step(np.zeros((3, 4)), np.zeros(3), np.zeros((4, 3)))


def test_kernel_refuses_what_it_cannot_run(kernel):
    with pytest.raises(sn.KernelUnavailable, match="float32"):
        sn.NativeStreamingCascade(_random_cascade(4, True, True).double(), 4)


def test_a_missing_compiler_falls_back_to_torch_with_a_warning(monkeypatch, tmp_path):
    from tendon_id.errors import TendonIdError
    from tendon_id.zoo.stream import PGCHTCStream

    monkeypatch.setattr(sn, "_loaded", None)
    monkeypatch.setattr(sn, "_failure", None)
    monkeypatch.setenv("TENDON_ID_CACHE", str(tmp_path))
    monkeypatch.setenv("CC", str(tmp_path / "no-such-cc"))

    class Model:  # what PGCHTCStream reads of a fitted PG-CHTC
        cascade_ = _random_cascade(4, True, True)
        n_modules_ = 4
        alpha_0_ = 0.1  # its prior's fitted routing wrap

    with pytest.warns(RuntimeWarning, match="no C compiler"):
        stream = PGCHTCStream(Model())
    assert stream.engine_name == "torch"
    assert stream.step(np.zeros((4, 2)), np.full((4, 3), 100.0)).shape == (4, 3)
    with pytest.raises(TendonIdError, match="native streaming engine is unavailable"):
        PGCHTCStream(Model(), "native")
    monkeypatch.setattr(sn, "_failure", None)
    monkeypatch.setenv("TENDON_ID_NATIVE", "0")  # switched off on purpose: no warning
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert PGCHTCStream(Model()).engine_name == "torch"


def test_the_thread_chooser_runs_the_faster_count_and_keeps_probing():
    from learners.thread_choice import ThreadChooser

    chooser = ThreadChooser(start=2, probe_every=8)
    cost = {1: 3.0e-3, 2: 2.0e-3}  # idle: the helper pays
    counts = []
    for frame in range(200):
        if frame == 100:
            cost = {1: 3.0e-3, 2: 5.0e-3}  # another process takes a core: one thread is faster
        t = chooser.next()
        chooser.record(t, cost[t])
        counts.append(t)
    assert counts[1] == 1  # the other count is timed early
    assert counts[50:100].count(2) >= 40 and counts[150:].count(1) >= 40
    assert 1 in counts[50:100] and 2 in counts[150:]  # still probing the other


def test_kernel_reads_every_float16_exactly(kernel):
    """The kernel's binary16 -> float32 conversion, for all 65 536 bit patterns, against numpy's."""
    bits = np.arange(1 << 16, dtype=np.uint16)
    y = np.empty(bits.size, np.float32)
    kernel.pgchtc_half_to_float(bits.ctypes.data, y.ctypes.data, bits.size)
    np.testing.assert_array_equal(y, bits.view(np.float16).astype(np.float32))  # NaN == NaN here


def test_software_float16_conversion_is_exact(kernel, tmp_path):
    """The same, for the portable conversion a CPU without F16C compiles (exact, so the same numbers everywhere)."""
    import ctypes
    import platform
    import shutil
    import subprocess

    if platform.machine() not in ("x86_64", "AMD64"):
        pytest.skip("-mno-f16c is an x86 flag")
    cc = shutil.which("gcc") or shutil.which("cc")  # the kernel fixture found one, so one is here
    lib = tmp_path / "half.so"
    cmd = [cc, "-O2", "-mno-f16c", "-std=gnu11", "-shared", "-fPIC", "-x", "c", str(sn.HEADER), "-o", str(lib)]
    subprocess.run(cmd, check=True, capture_output=True)
    half = ctypes.CDLL(str(lib))
    bits = np.arange(1 << 16, dtype=np.uint16)
    y = np.empty(bits.size, np.float32)
    half.pgchtc_half_to_float(ctypes.c_void_p(bits.ctypes.data), ctypes.c_void_p(y.ctypes.data), bits.size)
    np.testing.assert_array_equal(y, bits.view(np.float16).astype(np.float32))


def _frames(n, L, seed, n_tendons=3):
    g = torch.Generator().manual_seed(seed)
    return [
        (
            0.2 * torch.randn(n - 1, 4, generator=g).numpy(),
            (0.05 + 0.3 * torch.rand(n - 1, generator=g)).numpy(),
            (5.0 + 0.3 * torch.randn(n, n_tendons, generator=g)).numpy(),
        )
        for _ in range(L)
    ]


@pytest.mark.parametrize("n_tendons", [3, 2])
@pytest.mark.parametrize("tied", [True, False])
def test_float16_weights_stay_close_to_float32(kernel, tied, n_tendons):
    """Half-precision weights: near the float32 reference, and still one result for one or two threads."""
    n = 6
    cascade = _random_cascade(n, tied, True, seed=5, n_tendons=n_tendons)
    ref = sn.NativeStreamingCascade(cascade, n, threads=1)
    one = sn.NativeStreamingCascade(cascade, n, threads=1, weights="float16")
    two = sn.NativeStreamingCascade(cascade, n, threads=2, weights="float16")
    diffs = []
    for f in _frames(n, 17, seed=3, n_tendons=n_tendons):
        r, h = ref.step(*f), one.step(*f)
        np.testing.assert_array_equal(two.step(*f), h)
        diffs.append(np.max(np.abs(h - r)))
    # float16 rounds each weight by up to 2^-11 relative; through the tiny units and the chain
    # that moves ln T by about 1e-3 (measured 8.4e-4 tied, 1.0e-3 per guide), far above float32's 1e-6 (above).
    assert 1e-6 < max(diffs) < 5e-3


def test_float16_refuses_weights_beyond_its_range(kernel):
    cascade = _random_cascade(4, True, True)
    with torch.no_grad():
        cascade.units[0].backbone.head.bias[0] = 1e5
    with pytest.raises(ValueError, match="beyond float16"):
        sn.NativeStreamingCascade(cascade, 4, weights="float16")
    with pytest.raises(ValueError, match="weights must be"):
        sn.NativeStreamingCascade(cascade, 4, weights="int8")


def test_helper_threads_end_with_their_engines(kernel):
    """One helper thread per two-thread engine, started once and ended when the engine is collected."""
    import gc
    import os

    def threads_now():
        return len(os.listdir(f"/proc/{os.getpid()}/task"))

    if not os.path.isdir(f"/proc/{os.getpid()}/task"):
        pytest.skip("needs /proc to count threads")
    cascade = _random_cascade(4, True, True)
    frame = _frames(4, 1, seed=0)[0]
    before = threads_now()
    engines = [sn.NativeStreamingCascade(cascade, 4, threads=2) for _ in range(5)]
    for e in engines:
        e.step(*frame)
    assert threads_now() == before + 5
    del engines, e
    gc.collect()
    assert threads_now() == before


def test_a_forked_child_streams_with_its_own_helper(kernel):
    """A fork copies the engine but not its helper thread: the child starts its own instead of waiting forever,
    and ending the parent's helper from the child does nothing instead of joining a thread that is not there."""
    import multiprocessing as mp

    if "fork" not in mp.get_all_start_methods():
        pytest.skip("no fork here")
    cascade = _random_cascade(5, True, True)
    frames = _frames(5, 4, seed=6)
    engine = sn.NativeStreamingCascade(cascade, 5, threads=2)
    engine.step(*frames[0])  # the parent's helper has run
    parents_finalizer = engine._finalizer
    expected = sn.NativeStreamingCascade(cascade, 5, threads=1)
    want = [expected.step(*f) for f in frames][1:]
    ctx = mp.get_context("fork")
    receive, send = ctx.Pipe(duplex=False)

    def in_child():  # forked, so not pickled
        out = [engine.step(*f) for f in frames[1:]]
        parents_finalizer()  # what collecting the parent's engine object in the child would run
        engine.close()  # the child's own helper
        send.send(out)

    child = ctx.Process(target=in_child)
    child.start()
    try:
        assert receive.poll(60), "the forked child hung on a helper thread it does not have"
        got = receive.recv()
    finally:
        child.join(10)
        if child.is_alive():
            child.kill()
    assert child.exitcode == 0
    for g, w in zip(got, want):
        np.testing.assert_array_equal(g, w)


def test_close_ends_the_helper_and_a_later_frame_starts_another(kernel):
    import os

    if not os.path.isdir(f"/proc/{os.getpid()}/task"):
        pytest.skip("needs /proc to count threads")
    cascade = _random_cascade(4, True, True)
    frames = _frames(4, 3, seed=7)
    ref = sn.NativeStreamingCascade(cascade, 4, threads=1)
    engine = sn.NativeStreamingCascade(cascade, 4, threads=2)
    tasks = lambda: len(os.listdir(f"/proc/{os.getpid()}/task"))  # noqa: E731
    np.testing.assert_array_equal(engine.step(*frames[0]), ref.step(*frames[0]))
    before = tasks()
    engine.close()
    assert tasks() == before - 1
    engine.close()  # twice is fine
    np.testing.assert_array_equal(engine.step(*frames[1]), ref.step(*frames[1]))
    assert tasks() == before
