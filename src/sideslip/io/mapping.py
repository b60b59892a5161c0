"""Outside recordings (CSV with its own column names, MDF4) to a drive through a MAP.toml.

The map names, for each contract column, where its samples come from::

    [time]                       # optional
    channel = "time_s"           # CSV: the column of time stamps (default "t", "time" or
                                 # "timestamps"); MDF4: unused, every channel has its own time
    unit = "s"                   # "s" (default) or "ms"
    base = "wz"                  # optional: contract column whose samples are the rows of the
                                 # drive (default: the mapped column with the most samples)

    [can]                        # optional: raw CAN frames decoded with a DBC (cantools)
    dbc = "car.dbc"              # path, relative to the map file
    id = "CAN_ID"                # channel/column of arbitration ids
    data = "CAN_DATA"            # channel/column of payloads (MDF4: bytes or n x 8 uint8;
                                 # CSV: hex text such as "0A1B..." )
    bus = "CAN_BUS"              # optional channel/column of the bus number ...
    bus_value = 0                # ... and the bus to keep

    [columns.wz]
    channel = "YawRate"          # source channel (MDF4) or column (CSV) ...
    unit = "deg/s"
    sign = -1                    # optional, +1 (default) or -1: e.g. a right-positive sensor
    scale = 1.0                  # optional extra factor, e.g. 1/steering ratio
    time = "t_yaw"               # optional (CSV): this column's own time column

    [columns.steer]
    message = "STEER_ANGLE_SENSOR"   # ... or a DBC message and signal of the [can] frames
    signal = "STEER_ANGLE"
    unit = "deg"
    scale = 0.0593               # 1 / steering ratio: steering-wheel -> road-wheel angle

A value converts as ``column = sign * scale * value * unit_factor``; the unit factor comes from
the explicit table :data:`UNITS`, and a unit must fit the column's dimension (a speed column
rejects ``deg/s``).  Geodetic columns ``gnss_lat``/``gnss_lon``/``gnss_h`` (and ``ref_*``) are
accepted and turned into ENU by :func:`sideslip.drive.drive_from_columns`.

Several sample rates: the rows of the drive are the samples of the *base* column (the fast
sensor).  Every other column's samples land on the nearest base row (:func:`place_samples`);
rows without a sample stay NaN, and a sample is never repeated on a second row.  A bad map
raises one :class:`InputError` line naming the map file, the column and what was expected.
"""

from __future__ import annotations

import gc
import math
import sys
import tomllib
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numba
import numpy as np
import pandas as pd
from numpy.typing import NDArray

from sideslip.drive import COLUMNS, GEODETIC, Drive, drive_from_columns
from sideslip.errors import InputError

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.intp]

# unit -> (dimension, factor to SI)
UNITS: dict[str, tuple[str, float]] = {
    "rad": ("angle", 1.0),
    "deg": ("angle", math.pi / 180.0),
    "m/s": ("speed", 1.0),
    "km/h": ("speed", 1.0 / 3.6),
    "mph": ("speed", 0.44704),
    "m/s^2": ("acceleration", 1.0),
    "g": ("acceleration", 9.80665),
    "rad/s": ("rate", 1.0),
    "deg/s": ("rate", math.pi / 180.0),
    "m": ("length", 1.0),
    "s": ("time", 1.0),
    "ms": ("time", 1.0e-3),
}
_DIMENSION_OF_SI = {
    "rad": "angle", "m/s": "speed", "m/s^2": "acceleration", "rad/s": "rate", "m": "length",
    "s": "time",
}  # fmt: skip
FORMATS_MAPPED = ("csv", "mdf4")


def column_dimension(name: str) -> str | None:
    """Physical dimension of a contract (or geodetic) column, None if the name is unknown."""
    if name in COLUMNS:
        return _DIMENSION_OF_SI[COLUMNS[name]]
    for (lat, lon, h), _ in GEODETIC.items():
        if name in (lat, lon):
            return "angle"
        if name == h:
            return "length"
    return None


# ------------------------------------------------------------------------------------------
# placement of sparse samples on the rows of a fast time base
# ------------------------------------------------------------------------------------------
@numba.njit(cache=True)
def _place(base_t: NDArray, sample_t: NDArray, tol: float) -> NDArray:  # pragma: no cover
    n = base_t.size
    rows = np.full(sample_t.size, -1, dtype=np.int64)
    last = -1
    for i in range(sample_t.size):
        ts = sample_t[i]
        k = np.searchsorted(base_t, ts)
        if k >= n:
            k = n - 1
        elif k > 0 and ts - base_t[k - 1] <= base_t[k] - ts:
            k = k - 1
        if k <= last:
            k = last + 1  # nearest row already holds an earlier sample: next free row
        if k < n and abs(base_t[k] - ts) <= tol:
            rows[i] = k
            last = k
    return rows


@dataclass(frozen=True)
class Placement:
    """Where each sample of a sensor landed: ``rows[i]`` (-1 = dropped), with counts."""

    rows: IntArray
    moved: int
    dropped: int

    def spread(self, values: FloatArray, n_rows: int) -> FloatArray:
        """The sensor as a drive column: its samples on their rows, NaN elsewhere."""
        out = np.full(n_rows, np.nan)
        ok = self.rows >= 0
        out[self.rows[ok]] = np.asarray(values, dtype=float)[ok]
        return out


def place_samples(base_t: FloatArray, sample_t: FloatArray, tol: float | None = None) -> Placement:
    """Put each sample (times ``sample_t``, increasing) on the nearest row of ``base_t``.

    Samples are taken in time order.  When the nearest row already holds an earlier sample of
    the same sensor, the sample goes to the next free row, provided that row lies within
    ``tol`` s of the sample's time (default: the median base interval); otherwise the sample
    is dropped.  Samples farther than ``tol`` from every base row (before the first or after
    the last row) are dropped too.  No sample is ever put on two rows.
    """
    base_t = np.asarray(base_t, dtype=float)
    sample_t = np.asarray(sample_t, dtype=float)
    if tol is None:
        tol = float(np.median(np.diff(base_t))) if base_t.size > 1 else 0.0
    if base_t.size == 0 or sample_t.size == 0:
        return Placement(np.full(sample_t.size, -1, dtype=np.intp), 0, int(sample_t.size))
    rows = _place(base_t, sample_t, float(tol)).astype(np.intp)
    ok = rows >= 0
    nearest = np.clip(np.searchsorted(base_t, sample_t), 0, base_t.size - 1)
    prev = np.clip(nearest - 1, 0, base_t.size - 1)
    closer_prev = np.abs(base_t[prev] - sample_t) <= np.abs(base_t[nearest] - sample_t)
    nearest = np.where(closer_prev, prev, nearest)
    moved = int(np.count_nonzero(ok & (rows != nearest)))
    return Placement(rows, moved, int(np.count_nonzero(~ok)))


# ------------------------------------------------------------------------------------------
# the map file
# ------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class ColumnMap:
    """One contract column's source: a channel, or a DBC message/signal, with unit and sign."""

    column: str
    unit: str
    factor: float  # sign * scale * unit factor
    channel: str | None = None
    message: str | None = None
    signal: str | None = None
    time: str | None = None


@dataclass(frozen=True)
class SourceMap:
    """A parsed MAP.toml (see the module docstring)."""

    path: str
    columns: tuple[ColumnMap, ...]
    time_channel: str | None
    time_factor: float
    base: str | None
    can: dict[str, Any]


def _number(entry: dict[str, Any], key: str, default: float, path: str, col: str) -> float:
    raw = entry.get(key, default)
    if isinstance(raw, bool) or not isinstance(raw, int | float) or not math.isfinite(raw):
        raise InputError(path, f"'{key}' = {raw!r}: expected a finite number", column=col)
    return float(raw)


def load_map(map_path: str | Path) -> SourceMap:
    """Parse and check a MAP.toml; every problem is one InputError line naming the column."""
    path = str(map_path)
    try:
        table = tomllib.loads(Path(map_path).read_text(encoding="utf-8"))
    except OSError as exc:
        raise InputError(path, f"cannot read the map file ({exc.strerror})") from None
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise InputError(path, f"not valid TOML ({exc})") from None
    cols_raw = table.get("columns")
    if not isinstance(cols_raw, dict) or not cols_raw:
        raise InputError(path, "expected a [columns.<name>] table for each contract column")
    time_tab = table.get("time", {})
    if not isinstance(time_tab, dict):
        raise InputError(path, "expected [time] to be a table", column="t")
    time_unit = str(time_tab.get("unit", "s"))
    if time_unit not in ("s", "ms"):
        raise InputError(path, f"time unit '{time_unit}' unknown: expected s or ms", column="t")
    can = table.get("can", {})
    if not isinstance(can, dict):
        raise InputError(path, "expected [can] to be a table with dbc, id and data")
    uses_can = False
    columns: list[ColumnMap] = []
    for name, entry in cols_raw.items():
        dim = column_dimension(name)
        if dim is None or name == "t":
            raise InputError(
                path,
                "not a contract column: expected one of " + ", ".join(c for c in COLUMNS if c != "t"),
                column=name,
            )
        if not isinstance(entry, dict):
            raise InputError(path, "expected a table with channel (or message/signal) and unit",
                             column=name)
        unit = entry.get("unit")
        allowed = [u for u, (d, _) in UNITS.items() if d == dim]
        if unit is None:
            raise InputError(path, "unit missing: expected one of " + ", ".join(allowed),
                             column=name)
        if unit not in UNITS:
            raise InputError(path, f"unit '{unit}' unknown: expected one of " + ", ".join(allowed),
                             column=name)
        if UNITS[unit][0] != dim:
            raise InputError(
                path,
                f"unit '{unit}' is a {UNITS[unit][0]}, but this column is a {dim}: expected one "
                "of " + ", ".join(allowed),
                column=name,
            )
        sign = _number(entry, "sign", 1.0, path, name)
        if sign not in (1.0, -1.0):
            raise InputError(path, f"sign = {entry['sign']!r}: expected 1 or -1", column=name)
        scale = _number(entry, "scale", 1.0, path, name)
        if scale == 0.0:
            raise InputError(path, "scale = 0: expected a non-zero factor", column=name)
        channel = entry.get("channel")
        message, signal = entry.get("message"), entry.get("signal")
        if channel is not None and (message is not None or signal is not None):
            raise InputError(path, "give either channel or message/signal, not both", column=name)
        if channel is None and (message is None or signal is None):
            raise InputError(path, "expected channel = '<source channel>' or message and signal "
                             "of the DBC", column=name)
        if message is not None:
            uses_can = True
        time = entry.get("time")
        for key, val in (("channel", channel), ("message", message), ("signal", signal),
                         ("time", time)):
            if val is not None and not isinstance(val, str):
                raise InputError(path, f"{key} = {val!r}: expected a name in quotes", column=name)
        factor = UNITS[unit][1]
        if dim == "angle" and name not in COLUMNS:
            factor /= UNITS["deg"][1]  # geodetic lat/lon stay in degrees for the drive loader
        columns.append(ColumnMap(name, unit, sign * scale * factor, channel, message, signal, time))
    if uses_can:
        for key in ("dbc", "id", "data"):
            if not isinstance(can.get(key), str):
                raise InputError(path, f"[can] {key} missing: expected a name in quotes "
                                 "(DBC signals need dbc, id and data)")
        can = dict(can)
        dbc = Path(can["dbc"])
        can["dbc"] = str(dbc if dbc.is_absolute() else Path(map_path).parent / dbc)
    base = time_tab.get("base")
    if base is not None and base not in [c.column for c in columns]:
        raise InputError(path, f"[time] base = {base!r}: expected one of the mapped columns",
                         column="t")
    channel_t = time_tab.get("channel")
    return SourceMap(path, tuple(columns), None if channel_t is None else str(channel_t),
                     UNITS[time_unit][1], base, can)


# ------------------------------------------------------------------------------------------
# sources: CSV and MDF4, each giving (time, values) per channel
# ------------------------------------------------------------------------------------------
# A source channel is (time s, raw values, source row numbers from 1); rows name the CSV data
# row (header not counted) or the MDF4 sample / CAN frame, for messages.
Channel = tuple[FloatArray, np.ndarray, IntArray]


class _Csv:
    def __init__(self, path: str, smap: SourceMap) -> None:
        from sideslip.tables import _check_cells, _check_names, _csv_header

        self.path = path
        try:
            _check_names(_csv_header(Path(path)), path)
            self.frame = pd.read_csv(path, low_memory=False)
        except (OSError, ValueError, UnicodeDecodeError) as exc:
            first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
            raise InputError(path, f"cannot read as csv: {first[:200]}") from None
        _check_cells(self.frame, path)
        names = [str(c) for c in self.frame.columns]
        self.time = smap.time_channel or next(
            (c for c in ("t", "time", "timestamps", "timestamp") if c in names), None
        )
        if self.time is None or self.time not in names:
            raise InputError(smap.path, f"time column {self.time!r} not found in {path}: "
                             "expected [time] channel = one of " + ", ".join(names[:12]),
                             column="t")
        self.smap = smap

    def names(self) -> list[str]:
        return [str(c) for c in self.frame.columns]

    def raw(self, channel: str, time: str | None = None) -> Channel:
        tcol = time or self.time
        assert tcol is not None  # __init__ found the time column
        for name in (channel, tcol):
            if name not in self.frame.columns:
                raise KeyError(name)
        t_all = _numbers(self.frame[tcol].to_numpy(), self.path, tcol, "a time stamp")
        has_value = self.frame[channel].notna().to_numpy()
        no_time = has_value & np.isnan(t_all)
        if no_time.any():
            row = int(np.argmax(no_time)) + 1
            raise InputError(self.path, f"a value of {channel!r} without a time stamp: expected a "
                             "time in every row that holds a sample", channel=tcol, row=row)
        keep = has_value & np.isfinite(t_all)
        rows = np.flatnonzero(keep).astype(np.intp) + 1
        return t_all[keep] * self.smap.time_factor, self.frame[channel].to_numpy()[keep], rows


class _Mdf:
    def __init__(self, path: str, smap: SourceMap) -> None:
        from asammdf import MDF

        self.path = path
        error = None
        # a damaged file leaves a half-built reader whose __del__ fails and would print a
        # traceback at exit: collect it here, with the unraisable-exception hook silenced
        hook, sys.unraisablehook = sys.unraisablehook, lambda _: None
        try:
            try:
                self.mdf = MDF(path)
            except Exception as exc:  # asammdf raises many types on a bad file
                error = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
            if error is not None:
                gc.collect()
        finally:
            sys.unraisablehook = hook
        if error is not None:
            raise InputError(path, f"cannot read as mdf4: {error[:200]}")
        self.smap = smap

    def names(self) -> list[str]:
        return [n for n in self.mdf.channels_db if n not in ("time", "t")]

    def raw(self, channel: str, time: str | None = None) -> Channel:
        if channel not in self.mdf.channels_db:
            raise KeyError(channel)
        try:
            sig = self.mdf.get(channel)
        except Exception as exc:  # asammdf raises many types on a damaged block
            raise InputError(self.path, f"cannot read channel: {str(exc)[:200]}",
                             channel=channel) from None
        t = np.asarray(sig.timestamps, dtype=float)
        samples = np.asarray(sig.samples)
        if samples.shape[:1] != t.shape:
            raise InputError(self.path, f"{samples.shape[0]} samples but {t.size} time stamps: "
                             "expected one time stamp per sample", channel=channel)
        return t, samples, np.arange(1, t.size + 1, dtype=np.intp)


def _channel(src: _Csv | _Mdf, smap: SourceMap, name: str, col: str,
             time: str | None = None) -> Channel:
    try:
        return src.raw(name, time)
    except KeyError as missing:
        known = src.names()
        raise InputError(
            smap.path,
            f"channel {missing.args[0]!r} not found in {src.path}: expected one of "
            + ", ".join(known[:12]) + (" ..." if len(known) > 12 else ""),
            column=col,
        ) from None


def _numbers(values: np.ndarray, path: str, channel: str, what: str,
             rows: IntArray | None = None, col: str | None = None) -> FloatArray:
    """Raw cells as floats; text that is not a number and infinity are errors naming the row.

    Empty cells (NaN) stay NaN: a sensor without a sample there.
    """
    from sideslip.tables import _short

    if values.dtype.kind in "fiub":
        out = values.astype(float)
    else:
        out = pd.to_numeric(pd.Series(values), errors="coerce").to_numpy(dtype=float)
        bad = np.isnan(out) & pd.Series(values).notna().to_numpy()
        if bad.any():
            k = int(np.argmax(bad))
            raise InputError(path, f"expected {what}, got {_short(values[k])}", channel=channel,
                             column=col, row=int(rows[k]) if rows is not None else k + 1)
    inf = np.isinf(out)
    if inf.any():
        k = int(np.argmax(inf))
        raise InputError(path, f"expected {what} (finite) or an empty cell, got {out[k]}",
                         channel=channel, column=col,
                         row=int(rows[k]) if rows is not None else k + 1)
    return out


def _as_float(values: np.ndarray, rows: IntArray, src: str, smap: SourceMap, col: str,
              channel: str) -> FloatArray:
    if values.ndim > 1:
        raise InputError(smap.path, f"channel {channel!r} holds {values.shape[1]} values per "
                         "sample: expected a scalar channel (raw CAN goes through [can])",
                         column=col)
    cm = next((c for c in smap.columns if c.column == col), None)
    unit = f"a number in {cm.unit}" if cm is not None else "a number"
    out = _numbers(values, src, channel, unit, rows, col)
    if np.isnan(out).all() and out.size:
        raise InputError(smap.path, f"channel {channel!r} holds no numbers: expected a numeric "
                         "channel", column=col)
    return out


def _in_time_order(t: FloatArray, v: FloatArray, rows: IntArray, src: str, channel: str,
                   col: str) -> tuple[FloatArray, FloatArray, int]:
    """Check a channel's time stamps increase; drop exact repeats (same time, same value).

    A stamp earlier than the one before, or a repeated stamp with another value, is an error
    naming the source row (as ``estimate`` rejects time that is not strictly increasing): the
    order of the recording is broken and no choice of rows would be right.  A sample logged
    twice (same stamp and value) is dropped; the count is returned for a warning.
    """
    if t.size < 2:
        return t, v, 0
    step = np.diff(t)
    back = step < 0
    if back.any():
        k = int(np.argmax(back)) + 1
        raise InputError(src, f"time goes backwards, {t[k]:.9g} s after {t[k - 1]:.9g} s: expected "
                         "increasing time stamps", channel=channel, column=col, row=int(rows[k]))
    same = step == 0
    if not same.any():
        return t, v, 0
    clash = same & ~((v[1:] == v[:-1]) | (np.isnan(v[1:]) & np.isnan(v[:-1])))
    if clash.any():
        k = int(np.argmax(clash)) + 1
        raise InputError(src, f"two samples at {t[k]:.9g} s ({v[k - 1]:g} and {v[k]:g}): expected "
                         "one sample per time stamp", channel=channel, column=col, row=int(rows[k]))
    keep = np.r_[True, ~same]
    return t[keep], v[keep], int(np.count_nonzero(same))


def _limits(col: str, v: FloatArray, rows: IntArray, src: str, channel: str, unit: str) -> None:
    """Contract section 5's evident-unit limits on the converted values, naming the source row."""
    from sideslip.drive import LIMITS

    for names, limit, what in LIMITS:
        if col in names:
            over = np.abs(np.nan_to_num(v)) > limit
            if over.any():
                k = int(np.argmax(over))
                raise InputError(src, f"value {v[k]:g} is beyond {limit:g}: expected {what} "
                                 f"(the map says {unit})", channel=channel, column=col,
                                 row=int(rows[k]))


def read_mapped(path: str | Path, smap: SourceMap, fmt: str,
                warnings: list[str] | None = None) -> dict[str, tuple[FloatArray, FloatArray]]:
    """Every mapped column as (time s, value in SI) of its own samples (no alignment yet).

    Bad cells, infinity, time going backwards and evident unit mistakes are errors naming the
    source file, channel, column and row; samples logged twice are dropped with a line in
    ``warnings``.
    """
    if fmt not in FORMATS_MAPPED:
        raise InputError(str(path), f"format {fmt!r} unknown: expected one of "
                         + ", ".join(FORMATS_MAPPED))
    if not Path(path).is_file():
        raise InputError(str(path), "cannot read: no such file")
    src: _Csv | _Mdf = _Csv(str(path), smap) if fmt == "csv" else _Mdf(str(path), smap)
    out: dict[str, tuple[FloatArray, FloatArray]] = {}
    frames = None
    for cm in smap.columns:
        if cm.channel is not None:
            t, raw, rows = _channel(src, smap, cm.channel, cm.column, cm.time)
            values = _as_float(raw, rows, str(path), smap, cm.column, cm.channel)
            channel = cm.channel
        else:
            from sideslip.io.dbc import decode_signal_rows, load_dbc

            if frames is None:
                can = smap.can
                t_id, ids, id_rows = _channel(src, smap, can["id"], cm.column)
                t_data, data, _ = _channel(src, smap, can["data"], cm.column)
                if t_id.size != t_data.size:
                    raise InputError(smap.path, f"[can] id and data channels differ in length "
                                     f"({t_id.size} vs {t_data.size}): expected one row per "
                                     "frame", column=cm.column)
                keep = np.ones(t_id.size, dtype=bool)
                if "bus" in can:
                    _, bus, bus_rows = _channel(src, smap, str(can["bus"]), cm.column)
                    if bus.shape[:1] != t_id.shape:
                        raise InputError(smap.path, "[can] bus channel differs in length from id: "
                                         "expected one bus number per frame", column=cm.column)
                    keep = _as_float(bus, bus_rows, str(path), smap, cm.column,
                                     str(can["bus"])) == float(can.get("bus_value", 0))
                frames = (t_id[keep], np.asarray(ids)[keep], np.asarray(data)[keep],
                          load_dbc(can["dbc"]), id_rows[keep])
            assert cm.message is not None and cm.signal is not None
            t, values, k = decode_signal_rows(frames[3], cm.message, cm.signal, frames[0],
                                              frames[1], frames[2], source=smap.path,
                                              column=cm.column)
            rows = frames[4][k]
            channel = f"{cm.message}.{cm.signal}"
        t = np.asarray(t, dtype=float)
        ok = np.isfinite(values) & np.isfinite(t)
        v_si = values[ok] * cm.factor
        _limits(cm.column, v_si, rows[ok], str(path), channel, cm.unit)
        t_ok, v_ok, repeated = _in_time_order(t[ok], v_si, rows[ok], str(path), channel, cm.column)
        if repeated and warnings is not None:
            warnings.append(f"{path}: channel '{channel}': column '{cm.column}': {repeated} "
                            "sample(s) logged twice (same time stamp and value) dropped")
        out[cm.column] = (t_ok, np.asarray(v_ok, dtype=float))
    return out


def align(series: dict[str, tuple[FloatArray, FloatArray]], base: str | None,
          source: str) -> tuple[dict[str, FloatArray], dict[str, Any]]:
    """Columns on one time base: the base column's samples are the rows (see module doc).

    Returns the columns (``t`` included) and a placement report per column (samples, moved to
    the next free row, dropped).
    """
    nonempty = {k: v for k, v in series.items() if v[0].size}
    if not nonempty:
        raise InputError(source, "no mapped channel holds a sample: expected data")
    if base is None or base not in nonempty:
        base = max(nonempty, key=lambda k: nonempty[k][0].size)
    base_t, base_v = nonempty[base]
    uniq, first = np.unique(base_t, return_index=True)
    if uniq.size != base_t.size:
        base_t, base_v = uniq, base_v[first]
    cols: dict[str, FloatArray] = {"t": base_t, base: base_v}
    report: dict[str, Any] = {"base": base}
    for name, (t, v) in series.items():
        if name == base:
            continue
        pl = place_samples(base_t, t)
        cols[name] = pl.spread(v, base_t.size)
        report[name] = {"samples": int(t.size), "moved": pl.moved, "dropped": pl.dropped}
        if pl.dropped:
            report.setdefault("warnings", []).append(
                f"{source}: column '{name}': {pl.dropped} of {t.size} sample(s) dropped (outside "
                f"the time span of the base column '{base}' or no free row near them)")
    return cols, report


def convert_mapped(path: str | Path, map_path: str | Path, fmt: str) -> Drive:
    """A CSV or MDF4 recording to a validated drive, following the map file ``map_path``.

    ``fmt`` is "csv" or "mdf4".  Rows are the samples of the map's base column (default: the
    column with the most samples); see :func:`place_samples` for the slower sensors.
    """
    smap = load_map(map_path)
    warnings: list[str] = []
    series = read_mapped(path, smap, fmt, warnings)
    cols, report = align(series, smap.base, str(path))
    warnings += report.pop("warnings", [])
    meta = {
        "warnings": warnings,
        "source": f"{fmt}:{Path(path).name}",
        "map": str(map_path),
        "alignment": report,
        "notes": "rows are the samples of the base column; slower sensors sit on their nearest "
        "row (moved to the next free row on a collision, else dropped), NaN elsewhere",
    }
    return drive_from_columns(cols, meta, path=str(path))
