"""`sideslip evaluate --window`: every metric on the rows inside the window(s), and a window
outside the drive is one line."""

from __future__ import annotations

import json

import numpy as np
import pytest
from typer.testing import CliRunner

import sideslip as ss
from sideslip.cli import app
from sideslip.evaluate import evaluate_all
from tests.helpers import CIRCLE

METHODS = ["kinematic_integration", "fused", "kkf"]


@pytest.fixture(scope="module")
def est(tmp_path_factory):
    path = tmp_path_factory.mktemp("est") / "est.parquet"
    ss.estimate(CIRCLE, "midsize_sedan", methods=METHODS).save(path)
    return path


def invoke(*args):
    return CliRunner().invoke(app, [str(a) for a in args])


def test_window_restricts_every_metric_to_its_rows(est):
    res = invoke("evaluate", CIRCLE, est, "--window", "5:12", "--format", "json")
    assert res.exit_code == 0, res.output
    got = json.loads(res.stdout)
    drive = ss.load_drive(CIRCLE)
    rows = np.flatnonzero((drive.t >= 5) & (drive.t <= 12))
    part = drive.slice(rows[0], rows[-1] + 1)
    series = ss.estimate(CIRCLE, "midsize_sedan", methods=METHODS).series()
    expected = evaluate_all(part, {m: {k: v[rows] for k, v in s.items()} for m, s in series.items() if m})
    for m in METHODS:
        for key, value in expected[m].items():
            assert got[m][key] == pytest.approx(value, rel=1e-9, abs=1e-12), (m, key)
    whole = json.loads(invoke("evaluate", CIRCLE, est, "--format", "json").stdout)
    assert got["fused"]["pos_rmse_m"] != pytest.approx(whole["fused"]["pos_rmse_m"])  # it did restrict


def test_two_windows_pool_their_rows(est):
    res = invoke("evaluate", CIRCLE, est, "--window", "1:6", "--window", "12:19", "--format", "json")
    assert res.exit_code == 0, res.output
    got = json.loads(res.stdout)
    drive = ss.load_drive(CIRCLE)
    keep = ((drive.t >= 1) & (drive.t <= 6)) | ((drive.t >= 12) & (drive.t <= 19))
    beta = ss.estimate(CIRCLE, "midsize_sedan", methods=["kkf"])["kkf"]["beta"]
    err = np.degrees(beta[keep] - drive["ref_beta"][keep])
    assert got["kkf"]["beta_rmse_deg"] == pytest.approx(np.sqrt(np.mean(err**2)), rel=1e-9)
    assert "window_1-6_pos_mean_m" in got["fused"] and "window_12-19_pos_mean_m" in got["fused"]


@pytest.mark.parametrize("window", ["120:150", "15:25", "-3:2"])
def test_window_outside_the_drive_is_one_line(est, window):
    res = invoke("evaluate", CIRCLE, est, "--window", window)
    assert res.exit_code == 2
    assert res.stderr.strip() == (
        f"error: --window: '{window}' is outside the drive {CIRCLE}: expected T0:T1 within its time "
        "stamps 0:19.98 s"
    )
    assert res.stdout == ""
