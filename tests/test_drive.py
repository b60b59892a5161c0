"""Drive loading, saving and every bad-input rule of contract section 5 (one line each)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from sideslip.drive import SINGLE_PRECISION, drive_from_columns, load_drive, save_drive
from sideslip.errors import InputError
from sideslip.tables import meta_path
from tests.data.make_circle_drive import circle_columns
from tests.helpers import CIRCLE


def _write(tmp_path: Path, cols: dict, name: str = "d.csv") -> Path:
    p = tmp_path / name
    pd.DataFrame(cols).to_csv(p, index=False)
    return p


def _small() -> dict:
    return {k: v[:50] for k, v in circle_columns().items()}


def test_load_csv_keeps_contract_and_user_columns():
    drive = load_drive(CIRCLE)
    assert len(drive) == 1000
    assert "wz" in drive and "steer" in drive
    # the user's own column is carried through untouched
    assert drive.data["driver_note"][0] == "first half"
    # slow sensors leave NaN, never a repeated sample
    assert np.isnan(drive["gnss_e"][1]) and np.isfinite(drive["gnss_e"][5])


def test_parquet_roundtrip_keeps_metadata(tmp_path):
    drive = load_drive(CIRCLE)
    drive = drive_from_columns(
        {"t": drive.t, **drive.data}, meta={"origin": [35.0, 139.0, 10.0], "source": "test"}
    )
    out = tmp_path / "d.parquet"
    save_drive(drive, out)
    back = load_drive(out)
    assert back.meta["origin"] == [35.0, 139.0, 10.0]
    np.testing.assert_array_equal(back["wz"], drive["wz"])
    assert list(back.data["driver_note"][:2]) == ["first half", "first half"]


def test_csv_sidecar_metadata(tmp_path):
    cols = _small()
    drive = drive_from_columns(cols, meta={"source": "unit test"})
    out = tmp_path / "d.csv"
    save_drive(drive, out)
    assert json.loads(meta_path(out).read_text())["source"] == "unit test"
    assert load_drive(out).meta["source"] == "unit test"


def test_geodetic_columns_become_enu_about_origin(tmp_path):
    # 0.001 deg of latitude north of the origin is about 110.6 m north at 35 deg
    cols = {
        "t": [0.0, 1.0],
        "wz": [0.0, 0.0],
        "gnss_lat": [35.0, 35.001],
        "gnss_lon": [139.0, 139.0],
        "gnss_h": [10.0, 10.0],
    }
    drive = load_drive(_write(tmp_path, cols))
    assert drive.meta["origin"] == [35.0, 139.0, 10.0]
    assert drive["gnss_n"][1] == pytest.approx(110.95, abs=0.2)
    assert abs(drive["gnss_e"][1]) < 1e-6


@pytest.mark.parametrize(
    ("change", "needle"),
    [
        (lambda c: c.pop("t"), "column 't': required column is missing"),
        (
            lambda c: c["t"].__setitem__(10, c["t"][9]),
            "column 't': row 11: expected time stamps strictly increasing",
        ),
        (lambda c: c["t"].__setitem__(3, np.nan), "column 't': row 4: expected a time stamp in every row"),
        (lambda c: c["steer"].__setitem__(4, 15.0), "column 'steer': row 5: value 15 is beyond 1.2"),
        (lambda c: c["v_can"].__setitem__(6, 200.0), "column 'v_can': row 7: value 200 is beyond 150"),
        (lambda c: c["wz"].__setitem__(8, 14.3), "column 'wz': row 9: value 14.3 is beyond 5"),
        (lambda c: c["ay"].__setitem__(2, np.inf), "column 'ay': row 3: expected a finite number"),
        (lambda c: c["gnss_ve"].__setitem__(0, 400.0), "column 'gnss_ve': row 1: value 400 is beyond 150"),
        (lambda c: c["ref_roll"].__setitem__(1, 5.0), "column 'ref_roll': row 2: value 5 is beyond 1"),
    ],
)
def test_bad_values_name_file_column_row_and_expectation(tmp_path, change, needle):
    cols = _small()
    for k in list(cols):
        if k != "driver_note":
            cols[k] = np.array(cols[k], dtype=float)
    change(cols)
    p = _write(tmp_path, cols)
    with pytest.raises(InputError) as info:
        load_drive(p)
    msg = str(info.value)
    assert msg.startswith(str(p))
    assert needle in msg
    assert "\n" not in msg


def test_non_numeric_cell_is_named(tmp_path):
    cols = _small()
    cols["wz"] = cols["wz"].astype(object)
    cols["wz"][7] = "fast"
    p = _write(tmp_path, cols)
    with pytest.raises(InputError, match=r"column 'wz': row 8: expected a number in rad/s, got 'fast'"):
        load_drive(p)


@pytest.mark.parametrize("content", [b"\x00\x01garbage", b"PAR1 not really parquet"])
def test_unreadable_parquet_is_one_line(tmp_path, content):
    p = tmp_path / "broken.parquet"
    p.write_bytes(content)
    with pytest.raises(InputError, match=r"broken.parquet: cannot read as parquet"):
        load_drive(p)


def test_missing_file_and_wrong_extension(tmp_path):
    with pytest.raises(InputError, match="cannot read: no such file"):
        load_drive(tmp_path / "absent.csv")
    p = tmp_path / "drive.txt"
    p.write_text("t\n0\n")
    with pytest.raises(InputError, match=r"drive.txt: expected a .csv or .parquet file"):
        load_drive(p)


def test_loading_large_parquet_is_fast(tmp_path):
    """Regression guard: 360,000 rows x 30 columns load in well under a second (measured in
    benchmarks; 3 s here so a loaded CI machine does not flake)."""
    import time

    n = 360_000
    rng = np.random.default_rng(0)
    cols = {"t": np.arange(n) * 0.01}
    names = [
        "ax",
        "ay",
        "az",
        "wx",
        "wy",
        "wz",
        "v_fl",
        "v_fr",
        "v_rl",
        "v_rr",
        "v_can",
        "steer",
        "gnss_e",
        "gnss_n",
        "gnss_u",
        "gnss_ve",
        "gnss_vn",
        "gnss_vu",
        "ref_beta",
        "ref_yaw",
        "ref_roll",
        "ref_pitch",
        "ref_bank",
        "ref_e",
        "ref_n",
        "ref_u",
        "ref_vx",
        "ref_vy",
        "ref_r",
    ]
    for name in names:
        cols[name] = rng.normal(0, 0.1, n)
    p = tmp_path / "big.parquet"
    pd.DataFrame(cols).to_parquet(p)
    start = time.perf_counter()
    drive = load_drive(p)
    assert len(drive) == n
    assert time.perf_counter() - start < 3.0


# ------------------------------------------------------------------------------------------
# hostile tables (issue 17)
# ------------------------------------------------------------------------------------------
def test_column_named_twice_in_csv_is_one_line_naming_it(tmp_path):
    p = tmp_path / "dup.csv"
    p.write_text("t,wz,ay,wz\n0,0.1,0,0.2\n0.01,0.1,0,0.2\n")
    with pytest.raises(InputError) as info:
        load_drive(p)
    assert str(info.value) == (f"{p}: column 'wz': appears twice: expected each column once "
                               "(which one holds the data?)")


def test_column_named_twice_in_parquet_is_one_line_naming_it(tmp_path):
    import pyarrow as pa
    import pyarrow.parquet as pq

    p = tmp_path / "dup.parquet"
    arrays = [pa.array([0.0, 0.01]), pa.array([0.1, 0.1]), pa.array([0.2, 0.2])]
    pq.write_table(pa.table(arrays, names=["t", "wz", "wz"]), p)
    with pytest.raises(InputError, match=r"dup.parquet: column 'wz': appears twice"):
        load_drive(p)


@pytest.mark.parametrize("column", ["wz", "driver_note"])
def test_twenty_megabyte_cell_names_file_column_and_row(tmp_path, column):
    frame = pd.read_csv(CIRCLE).head(20)
    frame[column] = frame[column].astype(object)
    frame.loc[6, column] = "x" * (20 << 20)
    p = tmp_path / "big.csv"
    frame.to_csv(p, index=False)
    with pytest.raises(InputError) as info:
        load_drive(p)
    msg = str(info.value)
    assert msg.startswith(f"{p}: column '{column}': row 7: a cell of 20,971,520 characters")
    assert len(msg) < 300 and "\n" not in msg


def test_long_cell_in_parquet_is_named_too(tmp_path):
    p = tmp_path / "big.parquet"
    pd.DataFrame({"t": [0.0, 1.0], "wz": [0.0, 0.0], "note": ["ok", "y" * (2 << 20)]}).to_parquet(p)
    with pytest.raises(InputError, match=r"column 'note': row 2: a cell of 2,097,152 characters"):
        load_drive(p)


def test_malformed_csv_row_is_named(tmp_path):
    p = tmp_path / "ragged.csv"
    p.write_text("t,wz\n0,0.1\n0.01,0.1\n0.02,0.1,7,8\n")
    with pytest.raises(InputError) as info:
        load_drive(p)
    assert str(info.value).startswith(f"{p}: row 3: cannot read as csv:")


@pytest.mark.parametrize("rows", [0, 1])
def test_fewer_than_two_rows_say_what_is_needed(tmp_path, rows):
    p = _write(tmp_path, {k: v[:rows] for k, v in _small().items()})
    with pytest.raises(InputError) as info:
        load_drive(p)
    assert str(info.value) == (f"{p}: column 't': expected at least 2 rows (time stamps) to "
                               f"estimate anything, got {rows}")


def test_long_bad_text_in_a_numeric_column_is_cut_in_the_message(tmp_path):
    cols = _small()
    cols["wz"] = cols["wz"].astype(object)
    cols["wz"][3] = "z" * 5000
    p = _write(tmp_path, cols)
    with pytest.raises(InputError) as info:
        load_drive(p)
    msg = str(info.value)
    assert "column 'wz': row 4: expected a number in rad/s, got 'zzz" in msg
    assert "(5,000 characters)" in msg and len(msg) < 300


def test_side_car_that_is_not_an_object_is_one_line(tmp_path):
    p = _write(tmp_path, _small())
    meta_path(p).write_text("[1, 2]")
    with pytest.raises(InputError, match=r"d.meta.json: expected a JSON object of metadata"):
        load_drive(p)


def test_compact_drive_keeps_sensor_channels_in_float32_and_drops_the_reference():
    drive = load_drive(CIRCLE)
    small = drive.compact()
    assert not [c for c in small.data if c.startswith("ref_")]
    assert small.t is drive.t and small.data["gnss_e"] is drive.data["gnss_e"]  # shared
    assert small.data["driver_note"] is drive.data["driver_note"]  # the user's own: untouched
    # the bytes per row of a known column set: t and gnss_e/n/u stay 8 bytes, the sensor
    # channels of SINGLE_PRECISION take 4, the user's text column an 8-byte reference
    kept = [c for c in drive.data if not c.startswith("ref_")]
    single = [c for c in kept if c in SINGLE_PRECISION]
    assert {"wz", "ay", "steer", "v_rl"} <= set(single) and "gnss_e" not in single
    expected = 8 + 4 * len(single) + 8 * (len(kept) - len(single))
    assert small.nbytes() == expected * len(drive)
    assert drive.nbytes() > small.nbytes() * 1.4
    # methods still read float64, equal to the float32 rounding of the original samples
    assert small["wz"].dtype == np.float64
    np.testing.assert_array_equal(small["wz"], drive["wz"].astype(np.float32).astype(float))
    np.testing.assert_allclose(small["wz"], drive["wz"], rtol=6e-8, atol=0)


def test_compact_load_of_parquet_reads_no_reference_and_saves_double(tmp_path):
    out = tmp_path / "d.parquet"
    save_drive(load_drive(CIRCLE), out)
    small = load_drive(out, compact=True)
    assert "ref_beta" not in small.data and small.data["ay"].dtype == np.float32
    assert small.to_frame()["ay"].dtype == np.float64  # files keep double precision
    full = load_drive(out)  # the default load is exact: every column as stored
    assert full.data["ay"].dtype == np.float64 and "ref_beta" in full.data


def _wide_parquet(tmp_path: Path, n: int) -> tuple[Path, dict]:
    rng = np.random.default_rng(5)
    cols: dict = {"t": np.arange(n) * 0.01}
    for name in ("ax", "ay", "az", "wx", "wy", "wz", "v_fl", "v_fr", "v_rl", "v_rr", "steer",
                 "gnss_e", "gnss_n", "ref_beta", "ref_yaw", "ref_e", "my_channel"):  # fmt: skip
        cols[name] = rng.normal(0, 0.1, n)
    cols["gnss_e"][1::10] = np.nan  # a slower sensor
    p = tmp_path / "wide.parquet"
    pd.DataFrame(cols).to_parquet(p)
    return p, cols


def test_parquet_read_column_by_column_equals_the_whole_table(tmp_path):
    from sideslip.drive import validate_frame
    from sideslip.tables import read_table

    p, _ = _wide_parquet(tmp_path, 5000)
    frame, _meta = read_table(p)
    whole = validate_frame(frame, str(p))
    drive = load_drive(p)
    assert list(drive.data) == [c for c in whole if c != "t"]  # same columns, same order
    for name, values in whole.items():
        np.testing.assert_array_equal(drive[name] if name != "t" else drive.t, values)
    small = load_drive(p, compact=True)
    expected = drive.compact()
    assert list(small.data) == list(expected.data)
    for name in expected.data:
        assert small.data[name].dtype == expected.data[name].dtype
        np.testing.assert_array_equal(small.data[name], expected.data[name])
    no_ref = load_drive(p, reference=False)  # double precision, no truth columns
    assert no_ref.data["ay"].dtype == np.float64 and "ref_beta" not in no_ref.data


def test_loading_a_parquet_holds_one_column_beyond_the_drive(tmp_path):
    """Issue 17: the loader read the whole table, converted it to pandas and then to arrays
    (a 24 h drive of 2.2 GB peaked at 8.5 GB resident).  Read column by column, the child's
    peak resident memory grows by the drive's arrays plus a few columns in flight (arrow's
    buffers are not seen by tracemalloc, hence a child process and its peak RSS).  The
    18-column drive here: 18 columns held, 26 grown; before, 68."""
    import subprocess
    import sys

    n = 1_000_000
    p, cols = _wide_parquet(tmp_path, n)
    child = (
        "import sys, json\n"
        "from sideslip.bench import _status_kb\n"
        "from sideslip.drive import load_drive\n"
        "load_drive(sys.argv[2])\n"  # warm: lazy imports and first-call caches
        "before = _status_kb('VmHWM')\n"
        "d = load_drive(sys.argv[1])\n"
        "print(json.dumps([(_status_kb('VmHWM') - before) * 1024, d.nbytes()]))\n"
    )
    small = tmp_path / "small.parquet"
    pd.DataFrame({k: v[:100] for k, v in cols.items()}).to_parquet(small)
    # VmHWM (not ru_maxrss, which Linux carries over from the parent across exec)
    out = subprocess.run(
        [sys.executable, "-c", child, str(p), str(small)], capture_output=True, text=True, check=True
    )
    grown, held = json.loads(out.stdout.strip().splitlines()[-1])
    column = n * 8
    assert held == column * len(cols)
    # measured: the drive + 7.8 columns (one column read, its float64 values and the range
    # checks' temporaries); the whole-table read grew by the drive + 50 columns
    assert grown < held + 12 * column, (grown / column, held / column)


def test_bad_column_read_one_at_a_time_is_still_named_in_table_order(tmp_path):
    """Range checks wait for ``t``: a bad time stamp is named even if a later column (here a
    speed in km/h) is also wrong, as when the whole table was checked at once."""
    p = tmp_path / "bad.parquet"
    pd.DataFrame({"v_can": [10.0, 200.0, 10.0], "t": [0.0, 0.0, 0.02], "wz": [0.0, 0.0, 0.0]}).to_parquet(p)
    with pytest.raises(InputError, match=r"column 't'.*row 2.*strictly increasing, got 0.0 s after 0.0 s$"):
        load_drive(p)
    pd.DataFrame({"v_can": [10.0, 200.0, 10.0], "t": [0.0, 0.01, 0.02]}).to_parquet(p)
    with pytest.raises(InputError, match=r"column 'v_can'.*row 2.*value 200 is beyond 150"):
        load_drive(p)
