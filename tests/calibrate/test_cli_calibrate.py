"""`sideslip calibrate` as a user meets it: a fitted file that loads, a table in 80 columns,
one line for each bad input and nothing written on failure."""

from __future__ import annotations

import json
import tomllib

import pandas as pd

from sideslip.drive import save_drive
from sideslip.vehicle import load_vehicle, save_vehicle
from tests.conftest import sim_drive
from tests.helpers import CIRCLE, run_cli


def test_calibrate_writes_a_vehicle_file_that_loads_with_a_comment_per_fit(tmp_path):
    drive = sim_drive("demo", 0)
    drive_path = tmp_path / "demo.parquet"
    save_drive(drive, drive_path)
    right = load_vehicle(drive.meta["vehicle"])
    rough_path = tmp_path / "rough.toml"
    save_vehicle(right.with_changes(cf=0.7 * right.cf, cr=0.7 * right.cr), rough_path)
    out, js = tmp_path / "fitted.toml", tmp_path / "fitted.json"
    res = run_cli("calibrate", drive_path, "--vehicle", rough_path, "--out", out, "--json", js)
    assert res.returncode == 0, res.stderr
    fitted = load_vehicle(out)
    # the demo's fitted stiffness lands within 10 % of the right file's nominal (an effective
    # value a few per cent below it), far from the rough file's 30 % low
    assert abs(fitted.cf / right.cf - 1.0) < 0.1 and abs(fitted.cr / right.cr - 1.0) < 0.1
    text = out.read_text()
    assert "# fitted " in text and "rows" in text and "[notes]" in text and "[calibration]" in text
    table = tomllib.loads(text)
    assert "gyro_bias_rad_s" in table["calibration"] and "gyro_bias_rad_s_sigma" in table["calibration"]
    params = json.loads(js.read_text())
    assert params["details"]["cf"]["informed"] is True and params["cf_sigma"] > 0
    assert max(len(line) for line in res.stdout.splitlines()) <= 80
    assert "cf" in res.stdout and "fitted" in res.stdout


def test_calibrate_bad_drive_is_one_line_and_writes_nothing(tmp_path):
    frame = pd.read_csv(CIRCLE).head(200).drop(columns=["wz"])
    bad = tmp_path / "no_gyro.csv"
    frame.to_csv(bad, index=False)
    out = tmp_path / "fitted.toml"
    res = run_cli("calibrate", bad, "--vehicle", "midsize_sedan", "--out", out)
    assert res.returncode == 2
    lines = [ln for ln in res.stderr.splitlines() if ln.strip()]
    assert lines == [
        f"error: {bad}: column 'wz': calibrate needs the yaw-rate gyro, which is missing or empty"
    ]
    assert not out.exists()
    assert sorted(p.name for p in tmp_path.iterdir()) == ["no_gyro.csv"]


def test_calibrate_rejects_an_output_that_is_not_toml(tmp_path):
    out = tmp_path / "fitted.json"
    res = run_cli("calibrate", CIRCLE, "--vehicle", "midsize_sedan", "--out", out)
    assert res.returncode == 2
    assert res.stderr.strip() == f"error: {out}: expected an output path ending in .toml"
    assert not out.exists()


def test_calibrate_unknown_vehicle_is_one_line(tmp_path):
    res = run_cli("calibrate", CIRCLE, "--vehicle", tmp_path / "none.toml", "--out", tmp_path / "f.toml")
    assert res.returncode == 2
    assert len([ln for ln in res.stderr.splitlines() if ln.strip()]) == 1
    assert "cannot read vehicle file" in res.stderr
