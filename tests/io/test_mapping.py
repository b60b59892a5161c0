"""MAP.toml conversion: CSV and MDF4 round trips, DBC decoding, sample placement, bad maps.

Every file is created here (asammdf, cantools) in ``tmp_path``; the truth is the signal written.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from sideslip.errors import InputError
from sideslip.io import convert
from sideslip.io.mapping import convert_mapped, load_map, place_samples

pytestmark = pytest.mark.automotive

DBC_TEXT = """VERSION ""

BS_:

BU_: XXX

BO_ 170 WHEEL_SPEEDS: 8 XXX
 SG_ WHEEL_SPEED_FR : 7|16@0+ (0.01,-67.67) [0|250] "kph" XXX
 SG_ WHEEL_SPEED_FL : 23|16@0+ (0.01,-67.67) [0|250] "kph" XXX
 SG_ WHEEL_SPEED_RR : 39|16@0+ (0.01,-67.67) [0|250] "kph" XXX
 SG_ WHEEL_SPEED_RL : 55|16@0+ (0.01,-67.67) [0|250] "kph" XXX

BO_ 37 STEER_ANGLE_SENSOR: 8 XXX
 SG_ STEER_ANGLE : 3|12@0- (1.5,0) [-500|500] "deg" XXX
"""


# ------------------------------------------------------------------------------------------
# sample placement
# ------------------------------------------------------------------------------------------
def test_place_samples_lands_each_sample_on_nearest_row_without_repeats() -> None:
    base = np.arange(10) * 0.01
    pl = place_samples(base, np.array([0.0004, 0.0213, 0.0549, 0.0898]))
    np.testing.assert_array_equal(pl.rows, [0, 2, 5, 9])
    col = pl.spread(np.array([1.0, 2.0, 3.0, 4.0]), base.size)
    assert np.count_nonzero(np.isfinite(col)) == 4  # no sample repeated on a second row
    assert (pl.moved, pl.dropped) == (0, 0)


def test_place_samples_collision_moves_to_next_free_row_or_drops() -> None:
    base = np.arange(5) * 0.01
    # 0.011 and 0.012 are both nearest to row 1: the second goes to row 2 (0.008 s away, within
    # one base interval); 0.0125 would go to row 3, 0.0175 s away: dropped; 0.026 takes row 3
    # and 0.0305 (nearest row 3, taken) moves to row 4, 0.0095 s away.
    pl = place_samples(base, np.array([0.011, 0.012, 0.0125, 0.026, 0.0305]))
    np.testing.assert_array_equal(pl.rows, [1, 2, -1, 3, 4])
    assert (pl.moved, pl.dropped) == (2, 1)


def test_place_samples_drops_samples_outside_the_base() -> None:
    base = np.arange(5) * 0.01
    pl = place_samples(base, np.array([-0.5, 0.02, 0.9]))
    np.testing.assert_array_equal(pl.rows, [-1, 2, -1])


def test_place_samples_random_rates_never_repeat_and_stay_close() -> None:
    rng = np.random.default_rng(3)
    base = np.cumsum(rng.uniform(0.0095, 0.0097, 2000))  # ~104 Hz IMU
    can = np.sort(rng.uniform(base[0], base[-1], 1800))  # ~90 Hz irregular CAN
    pl = place_samples(base, can)
    kept = pl.rows[pl.rows >= 0]
    assert np.unique(kept).size == kept.size  # one sample per row at most
    assert np.all(np.diff(kept) > 0)  # time order kept
    tol = float(np.median(np.diff(base)))
    assert np.max(np.abs(base[kept] - can[pl.rows >= 0])) <= tol
    assert pl.dropped == can.size - kept.size


def test_mdf4_array_channel_mapped_as_scalar_is_an_error(tmp_path: Path) -> None:
    _write_mdf4_case(tmp_path)
    mp = tmp_path / "map.toml"
    mp.write_text('[columns.wz]\nchannel = "CAN_DataBytes"\nunit = "rad/s"\n')
    with pytest.raises(InputError, match=r"column 'wz': channel 'CAN_DataBytes' holds 8 values "
                       r"per sample: expected a scalar channel"):
        convert_mapped(tmp_path / "rec.mf4", mp, "mdf4")


# ------------------------------------------------------------------------------------------
# CSV with its own column names
# ------------------------------------------------------------------------------------------
def _write_csv_case(tmp_path: Path) -> tuple[Path, Path, dict[str, np.ndarray]]:
    n = 200
    t_ms = 1000.0 + 10.0 * np.arange(n)  # 100 Hz, in ms
    yaw_dps_right = 5.0 * np.sin(np.arange(n) / 20.0)  # sensor: deg/s, right-positive
    speed_kmh = np.where(np.arange(n) % 4 == 0, 72.0 + 0.01 * np.arange(n), np.nan)  # 25 Hz
    lat = np.where(np.arange(n) % 10 == 3, 48.0 + 1e-6 * np.arange(n), np.nan)  # 10 Hz
    lon = np.where(np.arange(n) % 10 == 3, 11.0, np.nan)
    frame = pd.DataFrame({"Zeit_ms": t_ms, "GierRate": yaw_dps_right, "V_Fzg": speed_kmh,
                          "Breite": lat, "Laenge": lon, "ay_g": 0.1 * np.ones(n)})
    csv = tmp_path / "rec.csv"
    frame.to_csv(csv, index=False)
    mp = tmp_path / "map.toml"
    mp.write_text(
        '[time]\nchannel = "Zeit_ms"\nunit = "ms"\n\n'
        '[columns.wz]\nchannel = "GierRate"\nunit = "deg/s"\nsign = -1\n\n'
        '[columns.v_can]\nchannel = "V_Fzg"\nunit = "km/h"\n\n'
        '[columns.ay]\nchannel = "ay_g"\nunit = "g"\n\n'
        '[columns.gnss_lat]\nchannel = "Breite"\nunit = "deg"\n\n'
        '[columns.gnss_lon]\nchannel = "Laenge"\nunit = "deg"\n'
    )
    return csv, mp, {"t": t_ms / 1000.0, "wz": -np.radians(yaw_dps_right),
                     "v_can": speed_kmh / 3.6}


def test_csv_own_column_names_units_and_signs(tmp_path: Path) -> None:
    csv, mp, truth = _write_csv_case(tmp_path)
    drive = convert_mapped(csv, mp, "csv")
    np.testing.assert_allclose(drive.t, truth["t"])  # ms -> s; wz (100 Hz) is the base
    np.testing.assert_allclose(drive["wz"], truth["wz"], rtol=1e-12)  # deg/s, right -> left
    np.testing.assert_allclose(drive["ay"], 0.980665)  # g -> m/s^2
    # 25 Hz speed: its samples on their own rows, NaN elsewhere, km/h -> m/s
    np.testing.assert_array_equal(np.isfinite(drive["v_can"]), np.isfinite(truth["v_can"]))
    np.testing.assert_allclose(drive["v_can"], truth["v_can"], rtol=1e-12)
    # geodetic -> ENU about the first fix: the origin row is (0, 0), one row per fix
    assert np.count_nonzero(np.isfinite(drive["gnss_e"])) == 20
    assert drive.meta["origin"][:2] == pytest.approx([48.000003, 11.0])
    first = int(np.flatnonzero(np.isfinite(drive["gnss_e"]))[0])
    assert drive["gnss_e"][first] == pytest.approx(0.0, abs=1e-6)


def test_convert_dispatches_csv_with_map(tmp_path: Path) -> None:
    csv, mp, truth = _write_csv_case(tmp_path)
    drive = convert("csv", csv, None, mp)
    np.testing.assert_allclose(drive["wz"], truth["wz"])


def test_convert_csv_without_map_is_one_line_error(tmp_path: Path) -> None:
    csv, _, _ = _write_csv_case(tmp_path)
    with pytest.raises(InputError, match=r"expected --map MAP\.toml"):
        convert("csv", csv, None, None)
    with pytest.raises(InputError, match="format 'rosbag2' unknown: expected one of"):
        convert("rosbag2", csv, None, None)


def test_csv_raw_can_hex_payloads_decoded_with_dbc(tmp_path: Path) -> None:
    cantools = pytest.importorskip("cantools")
    (tmp_path / "car.dbc").write_text(DBC_TEXT)
    db = cantools.database.load_file(str(tmp_path / "car.dbc"))
    msg = db.get_message_by_name("STEER_ANGLE_SENSOR")
    t = 0.01 * np.arange(50)
    angle = 1.5 * np.round(np.linspace(-40, 40, 50) / 1.5)  # on the 1.5 deg DBC grid
    hexes = [msg.encode({"STEER_ANGLE": a}).hex().upper() for a in angle]
    # the same message echoed on bus 1 (e.g. a gateway) with other values: filtered by bus
    echo = [msg.encode({"STEER_ANGLE": 99.0}).hex() for _ in angle]
    frame = pd.DataFrame({"t": np.r_[t, t + 0.002], "gyro": np.r_[0.01 * np.ones(50),
                          [np.nan] * 50], "id": 37, "data": hexes + echo, "bus": [0] * 50 + [1] * 50})
    frame.sort_values("t").to_csv(tmp_path / "log.csv", index=False)
    (tmp_path / "map.toml").write_text(
        '[can]\ndbc = "car.dbc"\nid = "id"\ndata = "data"\nbus = "bus"\nbus_value = 0\n\n'
        '[columns.wz]\nchannel = "gyro"\nunit = "rad/s"\n\n'
        '[columns.steer]\nmessage = "STEER_ANGLE_SENSOR"\nsignal = "STEER_ANGLE"\n'
        'unit = "deg"\nscale = 0.0625\n'
    )
    drive = convert_mapped(tmp_path / "log.csv", tmp_path / "map.toml", "csv")
    np.testing.assert_allclose(drive["steer"], np.radians(angle) * 0.0625, atol=1e-12)


# ------------------------------------------------------------------------------------------
# MDF4 + DBC round trip
# ------------------------------------------------------------------------------------------
def _write_mdf4_case(tmp_path: Path) -> dict[str, np.ndarray]:
    asammdf = pytest.importorskip("asammdf")
    cantools = pytest.importorskip("cantools")
    (tmp_path / "car.dbc").write_text(DBC_TEXT)
    db = cantools.database.load_file(str(tmp_path / "car.dbc"))
    rng = np.random.default_rng(7)
    t_imu = 0.01 * np.arange(300)  # 100 Hz
    wz = 0.2 * np.sin(t_imu)
    ay_g = 0.05 * np.cos(t_imu)
    t_gnss = 0.1 * np.arange(30) + 0.003  # 10 Hz, not on the IMU clock
    speed_mph = 30.0 + rng.normal(0, 0.1, 30)
    # CAN frames, 50 Hz per message, interleaved with an unrelated id
    t_can = np.sort(np.r_[0.02 * np.arange(150) + 0.001, 0.02 * np.arange(150) + 0.011,
                          0.02 * np.arange(150) + 0.015])
    ws_kph = 50.0 + 0.01 * np.round(100 * rng.normal(0, 1, 150)) / 1.0
    steer_deg = 1.5 * np.round(30 * np.sin(0.02 * np.arange(150)) / 1.5)
    ids, payloads = [], []
    k_w = k_s = 0
    for i in range(t_can.size):
        phase = i % 3
        if phase == 0:
            ids.append(170)
            payloads.append(db.get_message_by_name("WHEEL_SPEEDS").encode(
                {"WHEEL_SPEED_FL": ws_kph[k_w], "WHEEL_SPEED_FR": ws_kph[k_w],
                 "WHEEL_SPEED_RL": ws_kph[k_w], "WHEEL_SPEED_RR": ws_kph[k_w]}))
            k_w += 1
        elif phase == 1:
            ids.append(37)
            payloads.append(db.get_message_by_name("STEER_ANGLE_SENSOR").encode(
                {"STEER_ANGLE": steer_deg[k_s]}))
            k_s += 1
        else:
            ids.append(999)
            payloads.append(bytes(8))
    data = np.frombuffer(b"".join(payloads), dtype=np.uint8).reshape(-1, 8)
    mdf = asammdf.MDF(version="4.10")
    mdf.append([asammdf.Signal(np.degrees(wz), t_imu, name="YawRate", unit="deg/s"),
                asammdf.Signal(ay_g, t_imu, name="AccLat", unit="g")])
    mdf.append([asammdf.Signal(speed_mph, t_gnss, name="GpsSpeed", unit="mph")])
    mdf.append([asammdf.Signal(np.asarray(ids, dtype=np.uint32), t_can, name="CAN_ID"),
                asammdf.Signal(data, t_can, name="CAN_DataBytes")])
    mdf.save(tmp_path / "rec.mf4", overwrite=True)
    (tmp_path / "map.toml").write_text(
        '[can]\ndbc = "car.dbc"\nid = "CAN_ID"\ndata = "CAN_DataBytes"\n\n'
        '[columns.wz]\nchannel = "YawRate"\nunit = "deg/s"\n\n'
        '[columns.ay]\nchannel = "AccLat"\nunit = "g"\n\n'
        '[columns.gnss_ve]\nchannel = "GpsSpeed"\nunit = "mph"\n\n'
        '[columns.v_fl]\nmessage = "WHEEL_SPEEDS"\nsignal = "WHEEL_SPEED_FL"\nunit = "km/h"\n\n'
        '[columns.steer]\nmessage = "STEER_ANGLE_SENSOR"\nsignal = "STEER_ANGLE"\n'
        'unit = "deg"\nscale = 0.0625\nsign = -1\n'
    )
    return {"t": t_imu, "wz": wz, "ay": 9.80665 * ay_g, "t_gnss": t_gnss,
            "gnss_ve": speed_mph * 0.44704, "t_can_ws": t_can[0::3], "v_fl": ws_kph / 3.6,
            "t_can_st": t_can[1::3], "steer": -np.radians(steer_deg) * 0.0625}


def test_mdf4_dbc_round_trip_values_units_and_rates(tmp_path: Path) -> None:
    truth = _write_mdf4_case(tmp_path)
    drive = convert("mdf4", tmp_path / "rec.mf4", None, tmp_path / "map.toml")
    # the 100 Hz IMU is the base; values exact up to float32-free round trips
    np.testing.assert_allclose(drive.t, truth["t"])
    np.testing.assert_allclose(drive["wz"], truth["wz"], rtol=1e-12, atol=1e-15)
    np.testing.assert_allclose(drive["ay"], truth["ay"], rtol=1e-12)
    # 10 Hz GNSS: 30 samples on 30 distinct rows, each the nearest IMU row, mph -> m/s
    rows = np.flatnonzero(np.isfinite(drive["gnss_ve"]))
    assert rows.size == 30
    np.testing.assert_allclose(drive.t[rows], truth["t_gnss"], atol=0.005)
    np.testing.assert_allclose(drive["gnss_ve"][rows], truth["gnss_ve"], rtol=1e-12)
    # CAN decoded through the DBC: km/h -> m/s (DBC resolution 0.01 km/h), steering wheel
    # deg -> road-wheel rad with the map's scale and sign; the unrelated id 999 is ignored
    rows = np.flatnonzero(np.isfinite(drive["v_fl"]))
    assert rows.size == 150
    np.testing.assert_allclose(drive["v_fl"][rows], truth["v_fl"], atol=0.005 / 3.6)
    np.testing.assert_allclose(drive.t[rows], truth["t_can_ws"], atol=0.005)
    rows = np.flatnonzero(np.isfinite(drive["steer"]))
    np.testing.assert_allclose(drive["steer"][rows], truth["steer"], atol=1e-12)
    assert drive.meta["alignment"]["base"] == "wz"


# ------------------------------------------------------------------------------------------
# bad maps: one line naming the map file, the column, and what was expected
# ------------------------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("entry", "column", "expected"),
    [
        ('[columns.wz]\nchannel = "GierRate"\nunit = "furlong/s"\n', "wz",
         "unit 'furlong/s' unknown: expected one of rad/s, deg/s"),
        ('[columns.wz]\nchannel = "GierRate"\nunit = "km/h"\n', "wz",
         "unit 'km/h' is a speed, but this column is a rate: expected one of rad/s, deg/s"),
        ('[columns.wz]\nchannel = "GierRate"\n', "wz", "unit missing: expected one of"),
        ('[columns.yawrate]\nchannel = "GierRate"\nunit = "deg/s"\n', "yawrate",
         "not a contract column: expected one of ax"),
        ('[columns.wz]\nchannel = "GierRate"\nunit = "deg/s"\nsign = 2\n', "wz",
         "sign = 2: expected 1 or -1"),
        ('[columns.steer]\nmessage = "STEER"\nsignal = "ANGLE"\nunit = "deg"\n', None,
         "[can] dbc missing"),
    ],
)
def test_bad_map_is_one_line_naming_map_column_and_expectation(
    tmp_path: Path, entry: str, column: str | None, expected: str
) -> None:
    mp = tmp_path / "bad_map.toml"
    mp.write_text('[time]\nchannel = "Zeit_ms"\nunit = "ms"\n\n' + entry)
    with pytest.raises(InputError) as err:
        load_map(mp)
    text = str(err.value)
    assert "\n" not in text
    assert text.startswith(str(mp))
    if column is not None:
        assert f"column '{column}'" in text
    assert expected in text


def test_unknown_channel_names_the_channel_and_the_available_ones(tmp_path: Path) -> None:
    csv, _, _ = _write_csv_case(tmp_path)
    mp = tmp_path / "map.toml"
    mp.write_text('[time]\nchannel = "Zeit_ms"\nunit = "ms"\n\n'
                  '[columns.wz]\nchannel = "YawRate"\nunit = "deg/s"\n')
    with pytest.raises(InputError) as err:
        convert_mapped(csv, mp, "csv")
    text = str(err.value)
    assert text.startswith(f"{mp}: column 'wz': channel 'YawRate' not found in {csv}")
    assert "expected one of Zeit_ms, GierRate" in text


def test_unknown_mdf4_channel_and_dbc_message(tmp_path: Path) -> None:
    _write_mdf4_case(tmp_path)
    mp = tmp_path / "map.toml"
    mp.write_text(mp.read_text().replace('"YawRate"', '"Gyro_Z"'))
    with pytest.raises(InputError, match=r"column 'wz': channel 'Gyro_Z' not found in .*rec\.mf4"):
        convert_mapped(tmp_path / "rec.mf4", mp, "mdf4")
    mp.write_text(mp.read_text().replace('"Gyro_Z"', '"YawRate"')
                  .replace('"STEER_ANGLE_SENSOR"', '"STEERING"'))
    with pytest.raises(InputError, match=r"column 'steer': DBC message 'STEERING' not found: "
                       r"expected one of WHEEL_SPEEDS, STEER_ANGLE_SENSOR"):
        convert_mapped(tmp_path / "rec.mf4", mp, "mdf4")


def test_wrong_unit_evident_after_conversion_is_caught_by_validation(tmp_path: Path) -> None:
    # a yaw rate logged in deg/s but mapped as rad/s exceeds the 5 rad/s evident-unit limit
    csv, _, _ = _write_csv_case(tmp_path)
    pd.DataFrame({"t": [0.0, 0.01], "w": [90.0, 91.0]}).to_csv(csv, index=False)
    mp = tmp_path / "m.toml"
    mp.write_text('[columns.wz]\nchannel = "w"\nunit = "rad/s"\n')
    with pytest.raises(InputError, match=r"column 'wz': row 1: value 90 is beyond 5"):
        convert_mapped(csv, mp, "csv")


def test_unit_table_factors() -> None:
    from sideslip.io.mapping import UNITS

    assert UNITS["km/h"][1] == pytest.approx(1 / 3.6)
    assert UNITS["mph"][1] == pytest.approx(1609.344 / 3600)
    assert UNITS["deg/s"][1] == pytest.approx(math.pi / 180)
    assert UNITS["g"][1] == pytest.approx(9.80665)


# ------------------------------------------------------------------------------------------
# hostile sources (issue 17): nothing re-sorted, dropped or turned into NaN without a word
# ------------------------------------------------------------------------------------------
def _two_channel_csv(tmp_path: Path, t: list, w: list, v: list | None = None) -> tuple[Path, Path]:
    cols = {"time": t, "w": w}
    if v is not None:
        cols["v"] = v
    csv = tmp_path / "log.csv"
    pd.DataFrame(cols).to_csv(csv, index=False)
    mp = tmp_path / "m.toml"
    text = '[columns.wz]\nchannel = "w"\nunit = "deg/s"\n'
    if v is not None:
        text += '\n[columns.v_can]\nchannel = "v"\nunit = "km/h"\n'
    mp.write_text(text)
    return csv, mp


def test_csv_time_going_backwards_is_one_line_naming_channel_and_row(tmp_path: Path) -> None:
    csv, mp = _two_channel_csv(tmp_path, [0.0, 0.01, 0.02, 0.015, 0.03], [1.0, 2.0, 3.0, 4.0, 5.0])
    with pytest.raises(InputError) as info:
        convert_mapped(csv, mp, "csv")
    assert str(info.value) == (f"{csv}: channel 'w': column 'wz': row 4: time goes backwards, "
                               "0.015 s after 0.02 s: expected increasing time stamps")


def test_csv_text_and_infinity_in_a_mapped_channel_are_errors_not_nan(tmp_path: Path) -> None:
    csv, mp = _two_channel_csv(tmp_path, [0.0, 0.01, 0.02], [1.0, 2.0, 3.0],
                               [36.0, "fast", 36.0])
    with pytest.raises(InputError) as info:
        convert_mapped(csv, mp, "csv")
    assert str(info.value) == (f"{csv}: channel 'v': column 'v_can': row 2: expected a number in "
                               "km/h, got 'fast'")
    csv, mp = _two_channel_csv(tmp_path, [0.0, 0.01, 0.02], [1.0, 2.0, 3.0], [36.0, 36.0, np.inf])
    with pytest.raises(InputError, match=r"channel 'v': column 'v_can': row 3: expected a number "
                       r"in km/h \(finite\) or an empty cell, got inf"):
        convert_mapped(csv, mp, "csv")


def test_csv_text_in_the_time_column_and_values_without_time(tmp_path: Path) -> None:
    csv, mp = _two_channel_csv(tmp_path, [0.0, "noon", 0.02], [1.0, 2.0, 3.0])
    with pytest.raises(InputError, match=r"log.csv: channel 'time': row 2: expected a time stamp, "
                       r"got 'noon'"):
        convert_mapped(csv, mp, "csv")
    csv, mp = _two_channel_csv(tmp_path, [0.0, None, 0.02], [1.0, 2.0, 3.0])
    with pytest.raises(InputError, match=r"channel 'time': row 2: a value of 'w' without a time"):
        convert_mapped(csv, mp, "csv")


def test_sample_logged_twice_is_dropped_with_a_warning(tmp_path: Path) -> None:
    from typer.testing import CliRunner

    from sideslip.cli import app

    csv, mp = _two_channel_csv(tmp_path, [0.0, 0.01, 0.01, 0.02], [1.0, 2.0, 2.0, 3.0])
    drive = convert_mapped(csv, mp, "csv")
    np.testing.assert_allclose(drive.t, [0.0, 0.01, 0.02])
    assert drive.meta["warnings"] == [f"{csv}: channel 'w': column 'wz': 1 sample(s) logged twice "
                                      "(same time stamp and value) dropped"]
    res = CliRunner().invoke(app, ["convert", "csv", str(csv), "--map", str(mp), "--out",
                                   str(tmp_path / "d.parquet")])
    assert res.exit_code == 0
    assert "warning: " + drive.meta["warnings"][0] in res.stderr
    # the same stamp with another value is not a repeat: which one is right is unknown
    csv, mp = _two_channel_csv(tmp_path, [0.0, 0.01, 0.01, 0.02], [1.0, 2.0, 2.5, 3.0])
    with pytest.raises(InputError, match=r"channel 'w': column 'wz': row 3: two samples at 0.01 s"):
        convert_mapped(csv, mp, "csv")


def test_samples_outside_the_base_are_dropped_with_a_warning(tmp_path: Path) -> None:
    csv = tmp_path / "log.csv"
    pd.DataFrame({"time": [0.0, 0.01, 0.02, 5.0], "w": [1.0, 2.0, 3.0, None],
                  "v": [36.0, None, None, 36.0]}).to_csv(csv, index=False)
    mp = tmp_path / "m.toml"
    mp.write_text('[columns.wz]\nchannel = "w"\nunit = "deg/s"\n\n'
                  '[columns.v_can]\nchannel = "v"\nunit = "km/h"\n')
    drive = convert_mapped(csv, mp, "csv")
    assert drive.meta["warnings"] == [f"{csv}: column 'v_can': 1 of 2 sample(s) dropped (outside "
                                      "the time span of the base column 'wz' or no free row near them)"]


def test_evident_unit_mistake_names_the_source_row(tmp_path: Path) -> None:
    # a speed logged in km/h mapped as m/s: 180 km/h passes 150 "m/s" only on source row 4
    csv = tmp_path / "log.csv"
    pd.DataFrame({"time": 0.01 * np.arange(8), "w": np.zeros(8),
                  "v": [None, 100.0, None, 180.0, None, 100.0, None, 100.0]}).to_csv(csv, index=False)
    mp = tmp_path / "m.toml"
    mp.write_text('[columns.wz]\nchannel = "w"\nunit = "rad/s"\n\n'
                  '[columns.v_can]\nchannel = "v"\nunit = "m/s"\n')
    with pytest.raises(InputError) as info:
        convert_mapped(csv, mp, "csv")
    assert str(info.value) == (f"{csv}: channel 'v': column 'v_can': row 4: value 180 is beyond "
                               "150: expected a speed in m/s within +-150 (km/h or mph?) (the map "
                               "says m/s)")


def test_csv_source_with_a_column_named_twice(tmp_path: Path) -> None:
    csv = tmp_path / "log.csv"
    csv.write_text("time,w,w\n0,1,2\n0.01,1,2\n")
    mp = tmp_path / "m.toml"
    mp.write_text('[columns.wz]\nchannel = "w"\nunit = "rad/s"\n')
    with pytest.raises(InputError, match=r"log.csv: column 'w': appears twice"):
        convert_mapped(csv, mp, "csv")


def test_mdf4_time_going_backwards_and_infinity_are_named(tmp_path: Path) -> None:
    asammdf = pytest.importorskip("asammdf")
    t = np.array([0.0, 0.01, 0.02, 0.005, 0.04])
    mdf = asammdf.MDF(version="4.10")
    mdf.append([asammdf.Signal(np.ones(5), t, name="YawRate", unit="deg/s")])
    mdf.save(tmp_path / "rec.mf4", overwrite=True)
    mp = tmp_path / "m.toml"
    mp.write_text('[columns.wz]\nchannel = "YawRate"\nunit = "deg/s"\n')
    with pytest.raises(InputError) as info:
        convert_mapped(tmp_path / "rec.mf4", mp, "mdf4")
    assert str(info.value) == (f"{tmp_path / 'rec.mf4'}: channel 'YawRate': column 'wz': row 4: "
                               "time goes backwards, 0.005 s after 0.02 s: expected increasing time "
                               "stamps")
    mdf = asammdf.MDF(version="4.10")
    mdf.append([asammdf.Signal(np.array([1.0, np.inf, 1.0]), 0.01 * np.arange(3), name="YawRate",
                               unit="deg/s")])
    mdf.save(tmp_path / "rec.mf4", overwrite=True)
    with pytest.raises(InputError, match=r"channel 'YawRate': column 'wz': row 2: expected a number "
                       r"in deg/s \(finite\) or an empty cell, got inf"):
        convert_mapped(tmp_path / "rec.mf4", mp, "mdf4")
