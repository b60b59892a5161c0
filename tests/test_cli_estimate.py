"""`sideslip estimate` options for users of OxTS/VBOX tools, and skipped methods in the params."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
from typer.testing import CliRunner

from sideslip.cli import app
from sideslip.conventions import heading_north_cw_deg
from sideslip.frames import geodetic_to_enu
from tests.conftest import sim_drive
from tests.helpers import CIRCLE

ORIGIN = [48.78, 9.18, 250.0]


def invoke(*args):
    return CliRunner().invoke(app, [str(a) for a in args])


def test_heading_convention_adds_heading_from_north_clockwise_in_degrees(tmp_path):
    out = tmp_path / "e.csv"
    res = invoke("estimate", CIRCLE, "--vehicle", "midsize_sedan", "--method", "kkf", "--method", "fused",
                 "--heading-convention", "north-cw-deg", "--out", out)  # fmt: skip
    assert res.exit_code == 0, res.output
    frame = pd.read_csv(out)
    for m in ("kkf", "fused"):
        yaw = frame[f"{m}.yaw"].to_numpy()
        heading = frame[f"{m}.heading_deg"].to_numpy()
        assert np.all((heading >= 0) & (heading < 360))
        # heading and yaw point the same way: (sin, cos) of heading = (cos, sin) of yaw
        assert np.allclose(np.sin(np.radians(heading)), np.cos(yaw), atol=1e-9)
        assert np.allclose(np.cos(np.radians(heading)), np.sin(yaw), atol=1e-9)
    assert "fg_batch.heading_deg" not in frame.columns  # only where a method has a yaw
    # East is 90 deg from North, North 0, South 180
    assert heading_north_cw_deg(np.array([0.0, np.pi / 2, -np.pi / 2])).tolist() == [90.0, 0.0, 180.0]


def test_geodetic_output_uses_the_drives_origin(tmp_path):
    drive = tmp_path / "circle.csv"
    drive.write_bytes(CIRCLE.read_bytes())
    (tmp_path / "circle.meta.json").write_text(json.dumps({"origin": ORIGIN}))
    out = tmp_path / "e.parquet"
    res = invoke("estimate", drive, "--vehicle", "midsize_sedan", "--method", "fused", "--geodetic", "--out", out)
    assert res.exit_code == 0, res.output
    frame = pd.read_parquet(out)
    lat, lon = frame["fused.lat"].to_numpy(), frame["fused.lon"].to_numpy()
    assert abs(lat - ORIGIN[0]).max() < 0.01 and abs(lon - ORIGIN[1]).max() < 0.01  # a 60 m circle
    enu = geodetic_to_enu(lat, lon, np.full(lat.size, ORIGIN[2]), tuple(ORIGIN))
    # back to ENU: the estimate's own e, n within a millimetre (the round trip of the ellipsoid)
    assert np.allclose(enu[:, 0], frame["fused.e"], atol=1e-3)
    assert np.allclose(enu[:, 1], frame["fused.n"], atol=1e-3)


def test_geodetic_output_without_an_origin_is_one_line_and_writes_nothing(tmp_path):
    out = tmp_path / "e.parquet"
    res = invoke("estimate", CIRCLE, "--vehicle", "midsize_sedan", "--geodetic", "--out", out)
    assert res.exit_code == 2
    assert res.stderr.strip() == (
        f"error: {CIRCLE}: no ENU origin in the drive's metadata: expected origin = [lat, lon, h] "
        "(degrees, m) in its .meta.json for geodetic output"
    )
    assert not out.exists()


def test_bad_heading_convention_is_named():
    res = invoke("estimate", CIRCLE, "--vehicle", "midsize_sedan", "--heading-convention", "north", "--out", "e.csv")
    assert res.exit_code == 2
    assert "--heading-convention: 'north': expected one of enu-ccw-rad, north-cw-deg" in res.stderr


def test_a_drive_without_the_yaw_rate_gyro_is_one_line_and_writes_nothing(tmp_path):
    """The contract's drive table requires wz for all methods: without it the default run is
    bad input (exit 2, one line naming file and column); seed 005's gyro-free EKF still runs
    when named."""
    frame = pd.read_csv(CIRCLE).drop(columns=["wz"])
    drive = tmp_path / "no_gyro.csv"
    frame.to_csv(drive, index=False)
    out = tmp_path / "e.parquet"
    res = invoke("estimate", drive, "--vehicle", "midsize_sedan", "--out", out)
    assert res.exit_code == 2
    assert res.stderr.strip() == (
        f"error: {drive}: column 'wz': required column is missing or empty: expected the yaw-rate "
        "gyro in rad/s (every method but ekf_wss_sas needs it; --method ekf_wss_sas runs that one alone)"
    )
    assert sorted(p.name for p in tmp_path.iterdir()) == ["no_gyro.csv"]
    named = invoke("estimate", drive, "--vehicle", "midsize_sedan", "--method", "ekf_wss_sas", "--out", out)
    assert named.exit_code == 0, named.output
    assert "ekf_wss_sas.beta" in pd.read_parquet(out).columns


def test_a_drive_no_method_can_run_on_names_the_column_most_methods_lack(tmp_path):
    """Without any speed column (wheels or CAN) nothing runs: the one error line names the
    speed columns, which most methods list as missing, and nothing is written."""
    frame = pd.read_csv(CIRCLE)
    frame = frame.drop(columns=[c for c in frame.columns if c.startswith("v_")])
    drive = tmp_path / "no_speed.csv"
    frame.to_csv(drive, index=False)
    res = invoke("estimate", drive, "--vehicle", "midsize_sedan", "--out", tmp_path / "e.parquet")
    assert res.exit_code == 2
    last = res.stderr.strip().splitlines()[-1]
    assert last == (
        f"error: {drive}: column 'v_fl or v_fr or v_rl or v_rr or v_can': no method can run on this "
        "drive: most lack this column, missing or empty (the skipped reasons above say what each needs)"
    )
    assert sorted(p.name for p in tmp_path.iterdir()) == ["no_speed.csv"]


def test_skipped_methods_and_their_reasons_go_to_the_params(tmp_path):
    frame = pd.read_csv(CIRCLE).drop(columns=["steer"])
    drive = tmp_path / "nosteer.csv"
    frame.to_csv(drive, index=False)
    out = tmp_path / "e.parquet"
    res = invoke("estimate", drive, "--vehicle", "midsize_sedan", "--out", out)
    assert res.exit_code == 0, res.output
    params = json.loads((tmp_path / "e.params.json").read_text())
    assert params["_skipped"]["obs_bicycle"] == "drive lacks 'steer'"
    assert "skipped obs_bicycle: drive lacks 'steer'" in res.stderr
    assert "fused" in params and "obs_bicycle" not in params


def test_compact_reading_is_said_and_changes_only_the_last_digits(tmp_path):
    """``--compact`` (the default for drives over LONG_DRIVE_ROWS) holds the sensor channels
    in float32: a relative rounding of 6e-8 of the inputs, so the estimates move by far less
    than any method's accuracy (1e-5 rad = 0.0006 deg); the table's metadata says so."""
    import pyarrow.parquet as pq

    full, small = tmp_path / "full.parquet", tmp_path / "small.parquet"
    for out, flag in ((full, "--no-compact"), (small, "--compact")):
        res = invoke("estimate", CIRCLE, "--vehicle", "midsize_sedan", "--method", "kkf", "--method", "obs_bicycle",
                     flag, "--out", out)  # fmt: skip
        assert res.exit_code == 0, res.output
    assert "compact" in invoke("estimate", CIRCLE, "--vehicle", "midsize_sedan", "--method", "kkf", "--compact",
                               "--out", tmp_path / "x.parquet").output  # fmt: skip
    a, b = pd.read_parquet(full), pd.read_parquet(small)
    assert list(a.columns) == list(b.columns)
    for col in ("kkf.beta", "obs_bicycle.beta", "kkf.yaw"):
        assert np.abs(a[col] - b[col]).max() < 1e-5, col
    assert not a.equals(b)  # the inputs were rounded: not silently the same run
    meta_full = json.loads(pq.read_schema(full).metadata[b"sideslip"])
    meta_small = json.loads(pq.read_schema(small).metadata[b"sideslip"])
    assert "inputs" not in meta_full and "single precision" in meta_small["inputs"]


def test_long_drives_are_read_compact_by_default(tmp_path, monkeypatch):
    import sideslip.cli.estimate as cli_estimate

    monkeypatch.setattr(cli_estimate, "LONG_DRIVE_ROWS", 500)  # CIRCLE has 1000 rows
    out = tmp_path / "e.parquet"
    res = invoke("estimate", CIRCLE, "--vehicle", "midsize_sedan", "--method", "kkf", "--out", out)
    assert res.exit_code == 0, res.output
    assert "read the drive compact" in res.output
    monkeypatch.setattr(cli_estimate, "LONG_DRIVE_ROWS", 5000)
    res = invoke("estimate", CIRCLE, "--vehicle", "midsize_sedan", "--method", "kkf", "--out", out)
    assert res.exit_code == 0 and "compact" not in res.output


def test_a_lateral_acceleration_in_g_is_one_line_and_writes_nothing(tmp_path):
    """race_lap with ay logged in g (within the 100 m/s^2 range limit): in its turns ay
    follows speed x wz with slope 0.10 where m/s^2 read 0.99 (sideslip.units_check); exit 2,
    one line naming the file, the column and the row, nothing written."""
    drive = sim_drive("race_lap")
    frame = pd.DataFrame({"t": drive.t, **{k: np.asarray(v) for k, v in drive.data.items()}})
    frame["ay"] = frame["ay"] / 9.81
    path = tmp_path / "in_g.parquet"
    frame.to_parquet(path)
    out = tmp_path / "e.parquet"
    res = invoke("estimate", path, "--vehicle", drive.meta["vehicle"], "--out", out)
    assert res.exit_code == 2
    line = res.stderr.strip()
    assert "\n" not in line
    assert line.startswith(f"error: {path}: column 'ay': row ")
    assert "ay follows 0.101 x speed x wz" in line
    assert sorted(p.name for p in tmp_path.iterdir()) == ["in_g.parquet"]
