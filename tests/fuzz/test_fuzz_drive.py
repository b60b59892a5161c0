"""Property-based: the drive loader and `sideslip estimate` on random and hostile tables.

Every case ends in a validated drive (or an estimate) or in one InputError line naming the
file (and, for a bad cell, the column and row); never another exception, never a partial file.
"""

from __future__ import annotations

import math
import tempfile
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from sideslip.cli import app
from sideslip.drive import LIMITS, load_drive
from sideslip.errors import InputError
from tests.fuzz.common import (
    LIMIT_OF,
    RUNNER,
    TEXT,
    check_cli_outcome,
    count,
    drive_columns,
    fuzz_settings,
    write_table,
)
from tests.helpers import run_cli

SUFFIX = st.sampled_from([".csv", ".parquet"])


def _check_valid(drive, cols) -> None:
    assert np.all(np.diff(drive.t) > 0) and len(drive) >= 2
    for names, limit, _ in LIMITS:
        for name in names:
            if name in drive.data:
                v = drive.data[name]
                assert not np.isinf(v).any() and np.nanmax(np.abs(v), initial=0.0) <= limit
    for name, values in cols.items():
        if name != "t":
            np.testing.assert_array_equal(drive.data[name], values)


@given(cols=drive_columns(), suffix=SUFFIX)
@fuzz_settings(40)
def test_valid_random_drives_load_unchanged(cols, suffix):
    count("drive: valid random")
    with tempfile.TemporaryDirectory() as tmp:
        p = Path(tmp) / f"d{suffix}"
        write_table(cols, p)
        drive = load_drive(p)
        np.testing.assert_array_equal(drive.t, cols["t"])
        _check_valid(drive, cols)


# mutation -> expected (column, row from 1) of the error, or None when the case is valid
MUTATIONS = ["text", "inf", "-inf", "t_repeat", "t_backwards", "t_missing", "deg_for_rad",
             "kmh_for_ms"]


@given(cols=drive_columns(min_rows=3), suffix=SUFFIX, kind=st.sampled_from(MUTATIONS),
       data=st.data())
@fuzz_settings(120)
def test_one_hostile_cell_is_named_by_column_and_row(cols, suffix, kind, data):
    count("drive: hostile cell")
    n = cols["t"].size
    k = data.draw(st.integers(1, n - 1), label="row index")
    data_cols = [c for c in cols if c != "t"]
    expect: tuple[str, int] | None
    if kind.startswith("t_"):
        t = cols["t"].astype(object) if kind == "t_missing" else cols["t"].copy()
        if kind == "t_repeat":
            t[k] = t[k - 1]
        elif kind == "t_backwards":
            t[k] = t[k - 1] - 0.25 * (t[1] - t[0])
        else:
            t[k] = None
        cols["t"] = t
        expect = ("t", k + 1)
    elif kind in ("text", "inf", "-inf"):
        name = data.draw(st.sampled_from([*data_cols, "t"]), label="column")
        col = cols[name].astype(object)
        col[k] = data.draw(TEXT) if kind == "text" else float(kind)
        cols[name] = col
        expect = (name, k + 1)
    else:  # a unit mistake: a column in deg (or km/h) mapped as rad (or m/s)
        family = ("steer", "wx", "wy", "wz", "ref_r", "ref_roll", "ref_pitch", "ref_bank") \
            if kind == "deg_for_rad" else ("v_fl", "v_fr", "v_rl", "v_rr", "v_can", "gnss_ve")
        name = data.draw(st.sampled_from(family), label="column")
        base = cols.get(name)
        if base is None:
            base = np.full(n, 0.05 if kind == "deg_for_rad" else 10.0)
        base = base * (180.0 / math.pi if kind == "deg_for_rad" else 3.6)
        base[k] = (1.5 if kind == "deg_for_rad" else 45.0) * (180.0 / math.pi if kind == "deg_for_rad" else 3.6)
        cols[name] = base
        limit = LIMIT_OF[name][0]
        over = np.abs(np.nan_to_num(base)) > limit
        expect = (name, int(np.argmax(over)) + 1)
    with tempfile.TemporaryDirectory() as tmp:
        p = Path(tmp) / f"d{suffix}"
        write_table(cols, p)
        with pytest.raises(InputError) as info:
            load_drive(p)
    msg = str(info.value)
    assert "\n" not in msg and len(msg) < 400
    column, row = expect
    assert msg.startswith(f"{p}: column '{column}': row {row}: expected") or msg.startswith(
        f"{p}: column '{column}': row {row}: value"), msg


@given(cols=drive_columns(), suffix=SUFFIX, how=st.sampled_from(["truncate", "garbage", "flip"]),
       data=st.data())
@fuzz_settings(60)
def test_truncated_and_binary_files_end_in_a_drive_or_one_line(cols, suffix, how, data):
    count("drive: truncated/binary")
    with tempfile.TemporaryDirectory() as tmp:
        p = Path(tmp) / f"d{suffix}"
        write_table(cols, p)
        raw = p.read_bytes()
        if how == "truncate":
            raw = raw[: data.draw(st.integers(0, len(raw) - 1), label="cut")]
        elif how == "garbage":
            raw = data.draw(st.binary(min_size=0, max_size=2000), label="bytes")
        else:
            buf = bytearray(raw)
            for i in data.draw(st.lists(st.integers(0, len(raw) - 1), min_size=1, max_size=8)):
                buf[i] ^= 0xFF
            raw = bytes(buf)
        p.write_bytes(raw)
        try:
            drive = load_drive(p)
        except InputError as exc:
            msg = str(exc)
            assert msg.startswith(str(p)) and "\n" not in msg and len(msg) < 400, msg
            return
        assert np.all(np.diff(drive.t) > 0)


FAST_METHODS = st.sampled_from([["kinematic_integration"], ["ekf_positioning"], ["doppler_slip"],
                                ["kalman_gps", "roll_index"]])


@given(cols=drive_columns(max_rows=200), suffix=SUFFIX, methods=FAST_METHODS,
       kind=st.sampled_from(["none", "text", "inf", "t_repeat", "truncate"]), data=st.data())
@fuzz_settings(40)
def test_estimate_on_random_drives_writes_everything_or_nothing(cols, suffix, methods, kind, data):
    count("drive: estimate CLI in-process")
    n = cols["t"].size
    k = data.draw(st.integers(1, n - 1))
    if kind == "text":
        cols["t"] = cols["t"].astype(object)
        cols["t"][k] = "soon"
    elif kind == "inf" and len(cols) > 1:
        name = next(c for c in cols if c != "t")
        cols[name] = cols[name].copy()
        cols[name][k] = np.inf
    elif kind == "t_repeat":
        cols["t"] = cols["t"].copy()
        cols["t"][k] = cols["t"][k - 1]
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        p = d / f"d{suffix}"
        write_table(cols, p)
        if kind == "truncate":
            p.write_bytes(p.read_bytes()[: p.stat().st_size // 2])
        before = {x.name for x in d.iterdir()}
        args = ["estimate", str(p), "--vehicle", "midsize_sedan", "--out", str(d / "est.parquet")]
        for m in methods:
            args += ["--method", m]
        res = RUNNER.invoke(app, args)
        if check_cli_outcome(res, d, before):
            assert (d / "est.parquet").is_file() and (d / "est.params.json").is_file()


@pytest.mark.parametrize(
    ("content", "needle"),
    [
        (b"\x89PNG\r\n\x1a\n\x00\x00\x00\rIHDR" + bytes(range(256)), "cannot read as csv"),
        (b"t,wz,wz\n0,0,0\n1,0,0\n", "column 'wz': appears twice"),
        (b"t,wz\n0,0\n1,zero\n", "column 'wz': row 2: expected a number in rad/s, got 'zero'"),
    ],
)
def test_hostile_files_through_the_real_command(tmp_path, content, needle):
    count("drive: subprocess")
    p = tmp_path / "d.csv"
    p.write_bytes(content)
    res = run_cli("estimate", p, "--vehicle", "midsize_sedan", "--out", tmp_path / "e.parquet")
    assert res.returncode == 2
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and needle in lines[0] and "Traceback" not in res.stderr, res.stderr
    assert sorted(x.name for x in tmp_path.iterdir()) == ["d.csv"]
