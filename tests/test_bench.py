"""`sideslip bench`: results only where --out says, tiled long drives, per-method peak memory."""

from __future__ import annotations

import json

import numpy as np

from sideslip.bench import measure_in_subprocess, tiled_drive
from tests.conftest import sim_drive
from tests.helpers import run_cli


def test_bench_writes_its_results_only_into_the_out_folder(tmp_path):
    work = tmp_path / "elsewhere"
    work.mkdir()
    out = tmp_path / "results"
    res = run_cli("bench", "--hours", "0.003", "--method", "kinematic_integration", "--no-memory",
                  "--repeat", "2", "--out", out, "--cache", tmp_path / "cache", cwd=work)
    assert res.returncode == 0, res.stderr
    assert "kinematic_integration" in (out / "bench.md").read_text()
    assert "the fastest of 2 runs" in (out / "bench.md").read_text()
    rows = json.loads((out / "bench.json").read_text())["methods"]
    assert [r["method"] for r in rows] == ["kinematic_integration"] and rows[0]["samples_per_s"] > 0
    # the reported run is the fastest of the two
    assert len(rows[0]["runs_seconds"]) == 2 and rows[0]["seconds"] == min(rows[0]["runs_seconds"])
    assert list(work.iterdir()) == []  # nothing written where it ran


def test_bench_refuses_an_out_folder_that_is_a_file_before_running(tmp_path):
    target = tmp_path / "file"
    target.write_text("x")
    res = run_cli("bench", "--hours", "0.003", "--out", target, "--cache", tmp_path / "cache")
    assert res.returncode == 2
    assert f"error: {target}: --out: expected a folder, found a file" in res.stderr


def test_tiled_drive_goes_on_where_the_last_copy_stopped():
    base = sim_drive("step_steer")
    hours = 2.5 * (base.t[-1] - base.t[0]) / 3600.0
    long = tiled_drive(base, hours)
    n = len(base)
    assert len(long) == round(hours * 3600.0 / base.dt_median) + 1
    assert np.allclose(np.diff(long.t), base.dt_median)
    # at the seam the position moves on by about one step (the copy starts where it stopped),
    # nowhere near the route's length (bound: 1 m at the step steer's ~22 m/s and 0.01 s steps)
    seam = np.abs(np.diff(long["ref_e"][n - 2 : n + 2]))
    assert seam.max() < 1.0 and np.ptp(long["ref_e"]) > 2.0 * np.ptp(base["ref_e"])


def test_peak_memory_of_a_method_is_measured_in_its_own_process(tmp_path):
    r = measure_in_subprocess("fused", 0.01, cache=tmp_path / "cache")
    assert "error" not in r, r
    # fused keeps its RTS history: tens of bytes per row at the very least (measured ~1.6 kB)
    assert r["rows"] == 3601 and r["bytes_per_row"] > 50.0
    assert r["peak_rss_mb"] >= r["rss_before_mb"] and r["nonfinite"] == {}
