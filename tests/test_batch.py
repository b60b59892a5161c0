"""Fleet runs: many drives in parallel, a bad one reported and skipped, a summary written."""

from __future__ import annotations

import json

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
