"""Fleet runs: many drives in parallel, a bad one reported and skipped, a summary written."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest

from sideslip.batch import run_batch
from sideslip.drive import save_drive
from tests.conftest import sim_drive
from tests.helpers import CIRCLE, run_cli


def _drives(tmp_path):
    good = tmp_path / "step.parquet"
    save_drive(sim_drive("step_steer"), good)
    bad = tmp_path / "bad.csv"
    frame = pd.read_csv(CIRCLE).head(200)
    frame.loc[10, "steer"] = 20.0  # steering-wheel degrees where road-wheel rad belong
    frame.to_csv(bad, index=False)
    return good, bad


def test_batch_cli_runs_good_drives_and_reports_the_bad_one(tmp_path):
    good, bad = _drives(tmp_path)
    out = tmp_path / "out"
    res = run_cli("batch", good, bad, CIRCLE, "--vehicle", "seed003_sedan", "--out-dir", out,
                  "--workers", "2", "--method", "fused", "--method", "obs_modified")
    assert res.returncode == 1, res.stderr
    assert f"error: {bad}: column 'steer': row 11: value 20 is beyond 1.2" in res.stderr
    assert "2 of 3 drives done" in res.stdout
    summary = pd.read_csv(out / "summary.csv")
    step = summary[(summary["drive"] == str(good)) & (summary["method"] == "obs_modified")]
    # the compensated modified observer on the step steer: well under 0.3 deg (measured 0.07)
    assert float(step["beta_rmse_deg"].iloc[0]) < 0.3
    assert (out / "step_est.parquet").exists() and (out / "circle_drive_est.parquet").exists()
    assert not (out / "bad_est.parquet").exists()
    payload = json.loads((out / "summary.json").read_text())
    assert [p["error"] is None for p in payload] == [True, False, True]


def test_batch_rejects_a_bad_vehicle_once(tmp_path):
    res = run_cli("batch", CIRCLE, "--vehicle", "no_such_car", "--out-dir", tmp_path / "o")
    assert res.returncode == 2
    assert "no such vehicle file or preset" in res.stderr
    assert not (tmp_path / "o").exists()


@pytest.mark.filterwarnings("ignore::DeprecationWarning")
def test_batch_on_a_local_dask_cluster_matches_the_serial_run(tmp_path):
    pytest.importorskip("distributed", reason="dask[distributed] extra not installed")
    good, _ = _drives(tmp_path)
    serial = run_batch([str(good)], "seed003_sedan", tmp_path / "a", ["obs_modified"], workers=1)
    dask = run_batch([str(good)], "seed003_sedan", tmp_path / "b", ["obs_modified"], workers=1, use_dask=True)
    assert serial[0].metrics == dask[0].metrics


def _two_drives_same_name(tmp_path):
    """step.parquet in two folders: a step steer and a slalom (different content, same name)."""
    a = tmp_path / "monday" / "step.parquet"
    b = tmp_path / "tuesday" / "step.parquet"
    a.parent.mkdir()
    b.parent.mkdir()
    save_drive(sim_drive("step_steer"), a)
    save_drive(sim_drive("slalom_low_mu"), b)
    return a, b


def test_drives_with_one_file_name_in_two_folders_keep_both_estimates(tmp_path):
    a, b = _two_drives_same_name(tmp_path)
    out = tmp_path / "out"
    res = run_cli("batch", a, b, "--vehicle", "seed003_sedan", "--out-dir", out, "--workers", "1",
                  "--method", "obs_kinematic")
    assert res.returncode == 0, res.stderr
    assert "2 of 2 drives done" in res.stdout
    est_a = pd.read_parquet(out / "monday" / "step_est.parquet")
    est_b = pd.read_parquet(out / "tuesday" / "step_est.parquet")
    # each estimate is its own drive's: as long as the drive, and the two differ
    assert len(est_a) == len(sim_drive("step_steer")) and len(est_b) == len(sim_drive("slalom_low_mu"))
    summary = pd.read_csv(out / "summary.csv")
    assert sorted(summary["output"]) == ["monday/step_est.parquet", "tuesday/step_est.parquet"]
    assert summary["beta_rmse_deg"].nunique() == 2


def test_output_folder_that_is_a_file_is_refused_before_any_drive_runs(tmp_path):
    good, _ = _drives(tmp_path)
    target = tmp_path / "taken"
    target.write_text("not a folder")
    res = run_cli("batch", good, "--vehicle", "seed003_sedan", "--out-dir", target)
    assert res.returncode == 2
    assert f"error: {target}: --out-dir: expected a folder, found a file" in res.stderr


def test_console_aggregate_fits_80_columns_and_parquet_has_median_and_p95(tmp_path):
    a, b = _two_drives_same_name(tmp_path)
    out = tmp_path / "out"
    res = run_cli("batch", a, b, CIRCLE, "--vehicle", "seed003_sedan", "--out-dir", out, "--workers", "2",
                  "--method", "obs_kinematic", "--method", "roll_dfc")
    assert res.returncode == 0, res.stderr
    table = [ln for ln in res.stdout.splitlines() if ln.startswith(("method", "obs_kinematic", "roll_dfc"))]
    assert len(table) == 3 and all(len(ln) <= 80 for ln in table)
    agg = pd.read_parquet(out / "aggregate.parquet").set_index("method")
    summary = pd.read_csv(out / "summary.csv")
    beta = summary[summary["method"] == "obs_kinematic"]["beta_rmse_deg"].dropna().to_numpy()
    assert agg.loc["obs_kinematic", "beta_rmse_deg_median"] == pytest.approx(float(np.median(beta)), rel=1e-5)  # summary.csv keeps 6 digits
    assert agg.loc["obs_kinematic", "beta_rmse_deg_p95"] == pytest.approx(float(np.percentile(beta, 95)), rel=1e-5)
    assert agg.loc["obs_kinematic", "share_run"] == 1.0 and agg.loc["roll_dfc", "drives"] == 3


def _mtimes(out):
    return {p.name: p.stat().st_mtime_ns for p in out.rglob("*_est.*")}


def test_resume_skips_complete_drives_and_redoes_changed_or_damaged_ones(tmp_path):
    a, b = _two_drives_same_name(tmp_path)
    out = tmp_path / "out"
    first = run_batch([str(a), str(b)], "seed003_sedan", out, ["obs_kinematic"], workers=1)
    assert [r.status for r in first] == ["run", "run"]
    before = _mtimes(out)
    again = run_batch([str(a), str(b)], "seed003_sedan", out, ["obs_kinematic"], workers=1, resume=True)
    assert [r.status for r in again] == ["resumed", "resumed"]
    assert [r.metrics for r in again] == [r.metrics for r in first]
    assert _mtimes(out) == before  # nothing rewritten
    # a damaged output (same name, other bytes) is found by its hash, not by its presence
    est_a = out / "monday" / "step_est.parquet"
    est_a.write_bytes(est_a.read_bytes()[:-100])
    redo = run_batch([str(a), str(b)], "seed003_sedan", out, ["obs_kinematic"], workers=1, resume=True)
    assert [r.status for r in redo] == ["run", "resumed"]
    assert redo[0].metrics == first[0].metrics
    # an input changed in place, and another method set, are computed again
    save_drive(sim_drive("step_steer", seed=1), b)
    redo = run_batch([str(a), str(b)], "seed003_sedan", out, ["obs_kinematic"], workers=1, resume=True)
    assert [r.status for r in redo] == ["resumed", "run"]
    redo = run_batch([str(a), str(b)], "seed003_sedan", out, ["roll_dfc"], workers=1, resume=True)
    assert [r.status for r in redo] == ["run", "run"]
    # without --resume everything is computed
    redo = run_batch([str(a), str(b)], "seed003_sedan", out, ["roll_dfc"], workers=1)
    assert [r.status for r in redo] == ["run", "run"]


def test_resume_from_the_command_line_says_how_many_were_resumed(tmp_path):
    a, b = _two_drives_same_name(tmp_path)
    out = tmp_path / "out"
    args = ("batch", a, b, "--vehicle", "seed003_sedan", "--out-dir", out, "--method", "obs_kinematic")
    assert run_cli(*args).returncode == 0
    res = run_cli(*args, "--resume")
    assert res.returncode == 0, res.stderr
    assert "2 of 2 drives done (2 resumed)" in res.stdout


def test_fsspec_urls_for_inputs_and_outputs(tmp_path):
    a, b = _two_drives_same_name(tmp_path)
    out_url = f"file://{tmp_path}/remote_out"
    urls = [f"file://{a}", f"file://{b}"]
    res = run_batch(urls, "seed003_sedan", out_url, ["obs_kinematic"], workers=1)
    assert [r.status for r in res] == ["run", "run"]
    local = run_batch([str(a), str(b)], "seed003_sedan", tmp_path / "local_out", ["obs_kinematic"], workers=1)
    assert [r.metrics for r in res] == [r.metrics for r in local]
    assert (tmp_path / "remote_out" / "monday" / "step_est.parquet").exists()
    assert (tmp_path / "remote_out" / "aggregate.parquet").exists()
    assert not list((tmp_path / "remote_out").rglob("*.part"))
    again = run_batch(urls, "seed003_sedan", out_url, ["obs_kinematic"], workers=1, resume=True)
    assert [r.status for r in again] == ["resumed", "resumed"]


def test_a_missing_url_is_one_failed_drive_naming_it(tmp_path):
    good, _ = _drives(tmp_path)
    missing = f"file://{tmp_path}/nowhere/x.parquet"
    res = run_batch([str(good), missing], "seed003_sedan", tmp_path / "o", ["obs_kinematic"], workers=1)
    assert res[0].status == "run" and res[1].status == "failed"
    assert res[1].error == f"{missing}: cannot read: no such file"


def test_an_unknown_url_scheme_for_the_output_is_one_line(tmp_path):
    good, _ = _drives(tmp_path)
    res = run_cli("batch", good, "--vehicle", "seed003_sedan", "--out-dir", "nosuchscheme://bucket/out")
    assert res.returncode == 2
    assert res.stderr.startswith("error: nosuchscheme://bucket/out: cannot open this URL: ")
    assert "Traceback" not in res.stderr
