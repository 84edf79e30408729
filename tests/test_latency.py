"""The latency benchmark's contract: docs/cli.rst shape, streaming equal to batch, naive timed on a full window."""

from tendon_id.benchmarks.latency import latency


def test_latency_benchmark_reports_the_design_shape_and_streaming_equals_batch():
    r = latency(preset="tiny", naive_frames=4, trained=False)
    for key in ("n_modules", "preset", "streaming_ms_median", "naive_ms_median", "speedup", "max_rel_diff_vs_batch"):
        assert key in r
    assert r["n_modules"] == 12 and r["preset"] == "tiny"
    assert r["torch_max_rel_diff_vs_batch"] <= 1e-5  # the same operations as batch inference
    assert r["max_rel_diff_vs_batch"] <= 1e-5  # the default engine (the C kernel where it builds) too
    # Any engine: as close to float64 arithmetic as batch inference is.
    assert r["max_rel_diff_vs_float64"] <= 1.5 * r["batch_max_rel_diff_vs_float64"] + 1e-6
    assert r["speedup_vs_torch"] == r["torch_streaming_ms_median"] / r["streaming_ms_median"]
    assert r["naive_frames"] == 4  # timed after the tiny preset's 5-frame history has filled
    assert r["naive_max_rel_diff_vs_batch"] <= 1e-5  # the baseline computes the same estimates
    assert r["streaming_ms_median"] > 0 and r["speedup"] == r["naive_ms_median"] / r["streaming_ms_median"]
    if r["native_threads"] == 2:  # the one-thread run of the same engine, in the same benchmark
        assert r["native_threads_same_bits"] is True and r["native_one_thread_ms_median"] > 0
    # The exported steps, timed in the same run beside their streamers, agree with them (tests/export say how closely).
    exported = {row["model"]: row for row in r["exported"]}
    assert set(exported) == {"pg-chtc", "capstan-nonsmooth"}
    for name, row in exported.items():
        assert row["streamer_ms"] > 0
        for fmt in ("c", "onnx"):
            if row[f"{fmt}_ms"] is None:  # no compiler, or no onnxruntime: said why
                assert row["why"]
                continue
            assert row[f"{fmt}_speedup"] == row["streamer_ms"] / row[f"{fmt}_ms"]
            assert row[f"{fmt}_max_rel"] <= (1e-5 if name == "pg-chtc" else 1e-12)
        if row["c_ms"] is not None:
            assert row["c_same_in_c"] and row["c_ctypes_ms"] > 0  # the C driver computed what ctypes did
