"""Property-based: `convert csv --map` and `convert mdf4 --map` on random and hostile sources.

A source has its own channel names and units; the map is random but well-formed (bad maps
are tested in tests/io/test_mapping.py), or deliberately wrong in the unit.  Every case ends in
a validated drive or in one InputError line; a text cell, infinity or backwards time in a
mapped channel is named by channel and source row; `convert` writes everything or nothing.
"""

from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from hypothesis import given
from hypothesis import strategies as st

from sideslip.cli import app
from sideslip.errors import InputError
from sideslip.io.mapping import UNITS, column_dimension, convert_mapped
from tests.fuzz.common import LIMIT_OF, RUNNER, SCALE, TEXT, check_cli_outcome, count, fuzz_settings

pytestmark = pytest.mark.automotive
CANDIDATES = ["wz", "ay", "ax", "v_can", "v_fl", "steer", "gnss_ve", "wx"]


@st.composite
def source(draw):
    """(columns of the source in its own units, map entries, name of the time channel)."""
    n = draw(st.integers(2, 200))
    dt = draw(st.sampled_from([0.001, 0.01, 0.1]))
    rng = np.random.default_rng(draw(st.integers(0, 2**16)))
    chosen = draw(st.lists(st.sampled_from(CANDIDATES), min_size=1, max_size=5, unique=True))
    cols: dict[str, np.ndarray] = {"Zeit": 10.0 + dt * np.arange(n)}
    entries = {}
    for i, col in enumerate(chosen):
        dim = column_dimension(col)
        units = [u for u, (d, _) in UNITS.items() if d == dim]
        unit = draw(st.sampled_from(units))
        si = SCALE[col] * (0.2 + np.abs(rng.standard_normal(n))) * (0.3 if col == "steer" else 1.0)
        raw = si / UNITS[unit][1]
        every = draw(st.sampled_from([1, 1, 3, 10]))
        if every > 1:
            raw[np.arange(n) % every != 1] = np.nan
        name = f"Kanal_{i}"
        cols[name] = raw
        entries[col] = (name, unit)
    return cols, entries


def _map_text(entries, wrong_unit: str | None = None) -> str:
    out = ['[time]\nchannel = "Zeit"\n']
    for col, (name, unit) in entries.items():
        if col == wrong_unit:  # the map claims SI where the log holds deg/s or km/h etc.
            unit = {"angle": "rad", "rate": "rad/s", "speed": "m/s", "acceleration": "m/s^2"}[
                UNITS[unit][0]]
        out.append(f'[columns.{col}]\nchannel = "{name}"\nunit = "{unit}"\n')
    return "\n".join(out)


KINDS = ["none", "text", "inf", "backwards", "repeat", "nan_run", "wrong_unit", "truncate", "binary"]


@given(src=source(), kind=st.sampled_from(KINDS), data=st.data())
@fuzz_settings(120)
def test_convert_csv_map_on_hostile_sources(src, kind, data):
    count("convert csv --map")
    cols, entries = src
    n = cols["Zeit"].size
    names = [name for name, _ in entries.values()]
    wrong = None
    expect = None  # (channel, source row) an error must name
    backwards = False  # a channel has samples on both rows of a step back in time
    evident = None  # a column whose unit mistake section 5's limits make evident
    if kind in ("text", "inf"):
        ch = data.draw(st.sampled_from(names))
        rows = np.flatnonzero(np.isfinite(cols[ch]))
        k = int(data.draw(st.sampled_from(list(rows))))
        cols[ch] = cols[ch].astype(object)
        cols[ch][k] = data.draw(TEXT) if kind == "text" else np.inf
        expect = (ch, k + 1)
    elif kind in ("backwards", "repeat") and n >= 3:
        k = data.draw(st.integers(1, n - 1))
        cols["Zeit"] = cols["Zeit"].copy()
        cols["Zeit"][k] = cols["Zeit"][k - 1] - (0.0005 if kind == "backwards" else 0.0)
        backwards = kind == "backwards" and any(
            bool(np.isfinite(cols[c][k - 1]) and np.isfinite(cols[c][k])) for c in names)
    elif kind == "nan_run":
        ch = data.draw(st.sampled_from(names))
        a = data.draw(st.integers(0, n - 1))
        cols[ch] = cols[ch].copy()
        cols[ch][a : a + data.draw(st.integers(1, n))] = np.nan
    elif kind == "wrong_unit":
        wrong = data.draw(st.sampled_from(list(entries)))
        limit = LIMIT_OF.get(wrong, (np.inf, ""))[0]
        if np.nanmax(np.abs(cols[entries[wrong][0]]), initial=0.0) > limit:
            evident = wrong  # the log's numbers read as SI pass the section 5 limit
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        csv = d / "log.csv"
        pd.DataFrame(cols).to_csv(csv, index=False)
        if kind == "truncate":
            csv.write_bytes(csv.read_bytes()[: data.draw(st.integers(0, csv.stat().st_size))])
        elif kind == "binary":
            csv.write_bytes(data.draw(st.binary(max_size=800)))
        mp = d / "map.toml"
        mp.write_text(_map_text(entries, wrong))
        try:
            drive = convert_mapped(csv, mp, "csv")
        except InputError as exc:
            msg = str(exc)
            assert "\n" not in msg and len(msg) < 600, msg
            if expect is not None:
                assert msg.startswith(f"{csv}: channel '{expect[0]}': column '"), msg
                assert f": row {expect[1]}: expected a number" in msg, msg
            if backwards:
                assert "time goes backwards" in msg, msg
            if evident is not None:
                assert f"column '{evident}'" in msg and "is beyond" in msg, msg
        else:
            assert expect is None and not backwards and evident is None
            assert np.all(np.diff(drive.t) > 0)
            for col in entries:
                if col in drive.data:
                    assert not np.isinf(drive.data[col]).any()
        if data.draw(st.booleans(), label="through the CLI"):
            before = {x.name for x in d.iterdir()}
            res = RUNNER.invoke(app, ["convert", "csv", str(csv), "--map", str(mp), "--out",
                                      str(d / "drive.csv")])
            if check_cli_outcome(res, d, before):
                assert (d / "drive.csv").is_file() and (d / "drive.meta.json").is_file()


@given(src=source(), kind=st.sampled_from(["none", "inf", "backwards", "wrong_unit", "truncate"]),
       data=st.data())
@fuzz_settings(30)
def test_convert_mdf4_map_on_hostile_sources(src, kind, data):
    asammdf = pytest.importorskip("asammdf")
    count("convert mdf4 --map")
    cols, entries = src
    t = cols.pop("Zeit")
    wrong = data.draw(st.sampled_from(list(entries))) if kind == "wrong_unit" else None
    with tempfile.TemporaryDirectory() as tmp:
        d = Path(tmp)
        mdf = asammdf.MDF(version="4.10")
        expect = None
        for name, raw in cols.items():
            ok = np.isfinite(raw)
            tt, vv = t[ok].copy(), raw[ok].copy()
            if kind == "inf" and expect is None and vv.size:
                k = data.draw(st.integers(0, vv.size - 1))
                vv[k] = np.inf
                expect = (name, k + 1, "expected a number")
            if kind == "backwards" and expect is None and vv.size >= 3:
                k = data.draw(st.integers(1, vv.size - 1))
                tt[k] = tt[k - 1] - 0.0005
                expect = (name, k + 1, "time goes backwards")
            if vv.size:
                mdf.append([asammdf.Signal(vv, tt, name=name)])
        rec = d / "rec.mf4"
        mdf.save(rec, overwrite=True)
        if kind == "truncate":
            rec.write_bytes(rec.read_bytes()[: data.draw(st.integers(0, rec.stat().st_size))])
        mp = d / "map.toml"
        mp.write_text(_map_text(entries, wrong))
        try:
            drive = convert_mapped(rec, mp, "mdf4")
        except InputError as exc:
            msg = str(exc)
            assert "\n" not in msg and len(msg) < 600, msg
            if expect is not None:
                assert msg.startswith(f"{rec}: channel '{expect[0]}': column '"), msg
                assert f": row {expect[1]}: " in msg and expect[2] in msg, msg
        else:
            assert expect is None
            assert np.all(np.diff(drive.t) > 0)
        before = {x.name for x in d.iterdir()}
        res = RUNNER.invoke(app, ["convert", "mdf4", str(rec), "--map", str(mp), "--out",
                                  str(d / "drive.parquet")])
        check_cli_outcome(res, d, before)


@pytest.mark.parametrize("case", ["truncated_mdf4", "text_in_csv", "backwards_csv"])
def test_hostile_sources_through_the_real_command(tmp_path, case):
    from tests.helpers import run_cli

    count("convert: subprocess")
    mp = tmp_path / "map.toml"
    mp.write_text('[columns.wz]\nchannel = "w"\nunit = "deg/s"\n')
    if case == "truncated_mdf4":
        asammdf = pytest.importorskip("asammdf")
        mdf = asammdf.MDF(version="4.10")
        mdf.append([asammdf.Signal(np.ones(100), 0.01 * np.arange(100), name="w")])
        src = tmp_path / "rec.mf4"
        mdf.save(src, overwrite=True)
        src.write_bytes(src.read_bytes()[:300])
        fmt, needle = "mdf4", "cannot read as mdf4"
    else:
        src = tmp_path / "log.csv"
        t = [0.0, 0.01, 0.02, 0.03] if case == "text_in_csv" else [0.0, 0.01, 0.005, 0.03]
        w = [1.0, "NaN?", 1.0, 1.0] if case == "text_in_csv" else [1.0, 1.0, 1.0, 1.0]
        pd.DataFrame({"t": t, "w": w}).to_csv(src, index=False)
        fmt = "csv"
        needle = ("channel 'w': column 'wz': row 2: expected a number in deg/s, got 'NaN?'"
                  if case == "text_in_csv" else "channel 'w': column 'wz': row 3: time goes backwards")
    before = sorted(x.name for x in tmp_path.iterdir())
    res = run_cli("convert", fmt, src, "--map", mp, "--out", tmp_path / "drive.parquet")
    assert res.returncode == 2, res.stderr
    lines = res.stderr.strip().splitlines()
    assert len(lines) == 1 and needle in lines[0] and "Traceback" not in res.stderr, res.stderr
    assert sorted(x.name for x in tmp_path.iterdir()) == before
