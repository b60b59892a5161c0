"""The command line as a user meets it: end to end, and one clear line for each bad input."""

from __future__ import annotations

import json

import pandas as pd

from tests.helpers import CIRCLE, run_cli


def test_estimate_then_evaluate_end_to_end(tmp_path):
    est = tmp_path / "est.parquet"
    res = run_cli("estimate", CIRCLE, "--vehicle", "midsize_sedan", "--out", est)
    assert res.returncode == 0, res.stderr
    table = pd.read_parquet(est)
    assert "kinematic_integration.beta" in table.columns
    params = json.loads((tmp_path / "est.params.json").read_text())
    assert "kinematic_integration" in params
    mj = tmp_path / "m.json"
    res = run_cli("evaluate", CIRCLE, est, "--json", mj)
    assert res.returncode == 0, res.stderr
    metrics = json.loads(mj.read_text())
    # The analytic circle has beta' = a_y/V - r = 0 and true beta 0.02 rad: the open-loop
    # baseline starting from zero stays at zero, so its error is exactly -0.02 rad.
    m = metrics["kinematic_integration"]
    assert abs(m["beta_mean_err_deg"] + 1.1459) < 1e-3


def test_methods_lists_the_baseline():
    res = run_cli("methods")
    assert res.returncode == 0
    assert "kinematic_integration" in res.stdout


def _bad(tmp_path, **change):
    frame = pd.read_csv(CIRCLE).head(100)
    for col, (row, value) in change.items():
        frame[col] = frame[col].astype(object)
        frame.loc[row, col] = value
    p = tmp_path / "bad.csv"
    frame.to_csv(p, index=False)
    return p


def test_bad_drive_gives_one_line_no_traceback_and_writes_nothing(tmp_path):
    drive = _bad(tmp_path, steer=(9, 25.0))
    out = tmp_path / "est.parquet"
    res = run_cli("estimate", drive, "--vehicle", "midsize_sedan", "--out", out)
    assert res.returncode == 2
    lines = [ln for ln in res.stderr.splitlines() if ln.strip()]
    assert lines == [
        f"error: {drive}: column 'steer': row 10: value 25 is beyond 1.2: expected "
        "a road-wheel angle in rad within +-1.2 (degrees or steering-wheel angle?)"
    ]
    assert "Traceback" not in res.stderr
    assert not out.exists()
    assert list(tmp_path.iterdir()) == [drive]


def test_debug_shows_the_traceback(tmp_path):
    drive = _bad(tmp_path, t=(5, 0.0))
    res = run_cli("--debug", "estimate", drive, "--vehicle", "midsize_sedan", "--out", tmp_path / "o.csv")
    assert res.returncode != 0
    assert "Traceback" in res.stderr


def test_method_missing_column_is_named(tmp_path):
    frame = pd.read_csv(CIRCLE).drop(columns=["ay"])
    p = tmp_path / "noay.csv"
    frame.to_csv(p, index=False)
    res = run_cli(
        "estimate",
        p,
        "--vehicle",
        "midsize_sedan",
        "--method",
        "kinematic_integration",
        "--out",
        tmp_path / "o.csv",
    )
    assert res.returncode == 2
    assert "column 'ay': method 'kinematic_integration' needs this column" in res.stderr


def test_vehicle_lacking_parameter_is_named(tmp_path):
    car = tmp_path / "car.toml"
    car.write_text("[vehicle]\nmass = 1500\nlf = 1.2\n")
    res = run_cli("estimate", CIRCLE, "--vehicle", car, "--out", tmp_path / "o.csv")
    assert res.returncode == 2
    assert f"error: {car}: parameter 'lr' is missing" in res.stderr


def test_unknown_method_and_bad_window(tmp_path):
    res = run_cli(
        "estimate", CIRCLE, "--vehicle", "midsize_sedan", "--method", "magic", "--out", tmp_path / "o.csv"
    )
    assert res.returncode == 2 and "unknown method 'magic'" in res.stderr
    res = run_cli("evaluate", CIRCLE, CIRCLE, "--window", "abc")
    assert res.returncode == 2 and "expected T0:T1 in seconds" in res.stderr


def test_evaluate_rejects_estimates_of_another_drive(tmp_path):
    other = tmp_path / "other.csv"
    pd.DataFrame({"t": [0.0, 1.0], "kinematic_integration.beta": [0.0, 0.0]}).to_csv(other, index=False)
    res = run_cli("evaluate", CIRCLE, other)
    assert res.returncode == 2
    assert "column 't': expected the drive's time stamps" in res.stderr


def test_estimate_set_reaches_the_method_and_is_recorded_in_params(tmp_path):

    out = tmp_path / "e.csv"
    res = run_cli(
        "estimate",
        CIRCLE,
        "--vehicle",
        "midsize_sedan",
        "--method",
        "fg_batch",
        "--set",
        "fg_batch.lateral_acceleration=7",
        "--out",
        out,
    )
    assert res.returncode == 0, res.stderr
    params = json.loads((tmp_path / "e.params.json").read_text())
    assert params["fg_batch"]["settings"]["lateral_acceleration"] == 7.0


def test_estimate_config_file_and_bad_settings_are_one_line_and_write_nothing(tmp_path):

    cfg = tmp_path / "tuning.toml"
    cfg.write_text("[fg_batch]\nwindow = 2.5\n")
    out = tmp_path / "e.csv"
    res = run_cli("estimate", CIRCLE, "--vehicle", "midsize_sedan", "--config", cfg, "--out", out)
    assert res.returncode == 2 and not out.exists()
    assert "tuning.toml: fg_batch: setting 'window'" in res.stderr and "integer" in res.stderr
    res = run_cli("estimate", CIRCLE, "--vehicle", "midsize_sedan", "--set", "fg_batch.nope=1", "--out", out)
    assert res.returncode == 2 and "unknown setting 'nope'" in res.stderr and not out.exists()
    res = run_cli(
        "estimate", CIRCLE, "--vehicle", "midsize_sedan", "--set", "fg_batch.model_beta=-1", "--out", out
    )
    assert res.returncode == 2 and "model_beta" in res.stderr and "> 0" in res.stderr
    assert len(res.stderr.strip().splitlines()) == 1
