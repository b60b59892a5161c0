"""A drive (contract section 1): columns on one time base, validation (section 5), load/save.

Rows are numbered from 1 for the first data row (the CSV header is not a row), so "row 12" is
the 12th sample of the table in both CSV and Parquet.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable, Iterator, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pyarrow as pa
from numpy.typing import NDArray

from sideslip.errors import InputError
from sideslip.frames import geodetic_to_enu
from sideslip.outputs import atomic_write
from sideslip.tables import (
    _READ_ERRORS,
    REFERENCE_PREFIX,
    _check_names,
    _first_row,
    _parquet_columns,
    _read_csv,
    _read_sidecar,
    _short,
    _table_path,
    _unreadable,
    save_table,
)

_atomic_write = atomic_write  # the name the other modules import

FloatArray = NDArray[np.float64]

# Contract columns with their units (section 1).
COLUMNS: dict[str, str] = {
    "t": "s",
    "ax": "m/s^2", "ay": "m/s^2", "az": "m/s^2",
    "wx": "rad/s", "wy": "rad/s", "wz": "rad/s",
    "v_fl": "m/s", "v_fr": "m/s", "v_rl": "m/s", "v_rr": "m/s", "v_can": "m/s",
    "steer": "rad",
    "gnss_e": "m", "gnss_n": "m", "gnss_u": "m",
    "gnss_ve": "m/s", "gnss_vn": "m/s", "gnss_vu": "m/s",
    "gnss_pos_std": "m", "gnss_vel_std": "m/s",
    "ref_beta": "rad", "ref_yaw": "rad", "ref_roll": "rad", "ref_pitch": "rad", "ref_bank": "rad",
    "ref_e": "m", "ref_n": "m", "ref_u": "m",
    "ref_vx": "m/s", "ref_vy": "m/s", "ref_r": "rad/s", "ref_ay": "m/s^2",
}  # fmt: skip
# Contract columns a compact drive (:meth:`Drive.compact`) stores in single precision (float32:
# a 24-bit mantissa, a relative step of 6e-8, orders of magnitude below any vehicle sensor's
# noise): the sensor channels and the receiver's stds.  ``t``, positions (m from an origin that
# may be far away) and the user's own columns stay float64.  Storage only: ``drive[name]``
# always returns float64, so every method computes in double precision.  A drive loaded as
# it is keeps every column exactly as read (float64).
SINGLE_PRECISION = frozenset(
    ("ax", "ay", "az", "wx", "wy", "wz", "v_fl", "v_fr", "v_rl", "v_rr", "v_can", "steer",
     "gnss_ve", "gnss_vn", "gnss_vu", "gnss_pos_std", "gnss_vel_std")
)  # fmt: skip
WHEEL_SPEEDS = ("v_fl", "v_fr", "v_rl", "v_rr")
SPEED_COLUMNS = (*WHEEL_SPEEDS, "v_can")
# Geodetic input the loader turns into ENU: (lat, lon, h) -> (e, n, u).
GEODETIC = {
    ("gnss_lat", "gnss_lon", "gnss_h"): ("gnss_e", "gnss_n", "gnss_u"),
    ("ref_lat", "ref_lon", "ref_h"): ("ref_e", "ref_n", "ref_u"),
}

# Fewest rows a drive may have: every method needs one step of time (two stamps); a one-row
# table holds no motion and ends in singular least-squares systems.
MIN_ROWS = 2
# A long drive (rows; 5.6 h at 100 Hz): the CLI reads it compact by default (the sensor
# channels in single precision, :meth:`Drive.compact`, a relative rounding of 6e-8, far below
# any sensor's noise), and methods trade a little time for memory on it (e.g. ``fused``
# recomputes per-row inputs instead of holding them), so a day-long drive fits in 4 GB.
LONG_DRIVE_ROWS = 2_000_000

# Evident-unit limits (section 5): |value| beyond the limit means a wrong unit.
LIMITS: list[tuple[tuple[str, ...], float, str]] = [
    (("steer",), 1.2, "a road-wheel angle in rad within +-1.2 (degrees or steering-wheel angle?)"),
    (
        (*SPEED_COLUMNS, "gnss_ve", "gnss_vn", "gnss_vu", "ref_vx", "ref_vy"),
        150.0,
        "a speed in m/s within +-150 (km/h or mph?)",
    ),
    (("wx", "wy", "wz", "ref_r"), 5.0, "a rate in rad/s within +-5 (deg/s?)"),
    (("ax", "ay", "az", "ref_ay"), 100.0, "a specific force in m/s^2 within +-100"),
    (
        ("ref_roll", "ref_pitch", "ref_bank"),
        1.0,
        "an angle in rad within +-1.0 (degrees?)",
    ),
]


@dataclass(frozen=True)
class Drive:
    """Validated columns of one drive as numpy arrays on the time base ``t`` (s).

    ``data`` holds every column but ``t``: the contract's (float, NaN where a slower sensor has
    no sample; float32 for the channels of :data:`SINGLE_PRECISION` in a :meth:`compact`
    drive, read back as float64 through ``drive[name]``) and any of the user's own, carried
    through untouched.  ``meta`` holds the
    side-car metadata (``origin``, ``source``, notes).  ``path`` names the file for messages.
    """

    t: FloatArray
    data: Mapping[str, np.ndarray]
    meta: Mapping[str, Any] = field(default_factory=dict)
    path: str = "<memory>"

    def __len__(self) -> int:
        return int(self.t.size)

    def __contains__(self, name: object) -> bool:
        """True when the column exists and holds at least one finite sample."""
        if not isinstance(name, str):
            return False
        if name == "t":
            return True
        col = self.data.get(name)
        if col is None or col.dtype.kind not in "fiu":
            return False
        return bool(np.isfinite(col).any())

    def __getitem__(self, name: str) -> FloatArray:
        """The column as float64 (a fresh copy for a column stored as float32)."""
        if name == "t":
            return self.t
        return np.asarray(self.data[name], dtype=float)

    def get(self, name: str) -> FloatArray | None:
        """The column as float array, or None when absent or empty."""
        return self[name] if name in self else None

    def columns(self) -> Iterator[str]:
        yield "t"
        yield from self.data

    @property
    def dt_median(self) -> float:
        """Median sample interval, s."""
        return float(np.median(np.diff(self.t))) if self.t.size > 1 else 0.0

    def nbytes(self) -> int:
        """Bytes the drive's arrays hold (``t`` and every column)."""
        return int(self.t.nbytes + sum(np.asarray(v).nbytes for v in self.data.values()))

    def without_reference(self) -> Drive:
        """The same drive without its ``ref_*`` truth columns (no copy): what the methods see.

        The reference is for evaluation only; dropping it frees its memory where a drive is
        only estimated on (benchmarks, long drives)."""
        data = {k: v for k, v in self.data.items() if not k.startswith(REFERENCE_PREFIX)}
        return Drive(self.t, data, self.meta, self.path)

    def compact(self) -> Drive:
        """The drive as the methods need it, in about 40 % of the memory: no ``ref_*`` truth
        columns, the sensor channels of :data:`SINGLE_PRECISION` as float32 (``t``, positions
        and the user's columns shared, not copied).  Methods read float64 (``drive[name]``), so
        their results change by the float32 rounding of their inputs only (relative 6e-8).
        For estimating on long drives; evaluate against the full drive."""
        data = {k: _stored(k, v) for k, v in self.without_reference().data.items()}
        return Drive(self.t, data, self.meta, self.path)

    def to_frame(self) -> pd.DataFrame:
        """The drive as a table, every float column in double precision (as files hold it)."""
        return pd.DataFrame({"t": self.t, **{k: _double(v) for k, v in self.data.items()}})

    def slice(self, start: int, stop: int) -> Drive:
        """Rows [start, stop) as a new drive (same metadata)."""
        return Drive(
            self.t[start:stop], {k: v[start:stop] for k, v in self.data.items()}, self.meta, self.path
        )


def _double(values: Any) -> np.ndarray:
    arr = np.asarray(values)
    return arr.astype(np.float64) if arr.dtype == np.float32 else arr


def _stored(name: str, values: np.ndarray) -> np.ndarray:
    """A column as a compact drive keeps it (:data:`SINGLE_PRECISION`)."""
    arr = np.asarray(values)
    return arr.astype(np.float32) if name in SINGLE_PRECISION and arr.dtype.kind == "f" else arr


# ------------------------------------------------------------------------------------------
# validation
# ------------------------------------------------------------------------------------------
def validate_frame(frame: pd.DataFrame, path: str, store: Store | None = None) -> dict[str, np.ndarray]:
    """Apply contract section 5 to a table; return its columns as arrays.

    Raises :class:`InputError` on the first violated rule, naming file, column, row and what
    was expected.  ``store``: see :func:`validate_columns`.
    """
    names = [str(c) for c in frame.columns]
    return validate_columns(names, ((str(c), frame[c]) for c in frame.columns), path, store)


# How a validated column is kept: (name, float64 values) -> the array the drive holds.
Store = Callable[[str, np.ndarray], np.ndarray]
# Checks made once ``t`` is known to be valid, in this order (the first failing one is named).
_DEFERRED = [n for names, _, _ in LIMITS for n in names] + ["gnss_pos_std", "gnss_vel_std"]


def validate_columns(
    names: list[str], columns: Iterable[tuple[str, pd.Series]], path: str, store: Store | None = None
) -> dict[str, np.ndarray]:
    """:func:`validate_frame` over columns that arrive one at a time (``names``: all of them).

    Each column is checked, turned into its array and passed through ``store`` (e.g. to float32,
    :func:`_stored`) before the next one is read, so a large file never needs its whole table
    and its arrays in memory at once.  The range and std checks wait until ``t`` has passed
    its own, so the error named is the same whatever the column order.
    """
    _check_names(names, path)
    if "t" not in names:
        raise InputError(path, "required column is missing: expected time stamps in s", column="t")
    out: dict[str, np.ndarray] = {}
    deferred: dict[str, InputError] = {}
    for name_s, series in columns:
        values = _column_values(name_s, series, path)
        error = _range_error(name_s, values, path)
        if error is not None:
            deferred[name_s] = error
        out[name_s] = store(name_s, values) if store is not None and name_s != "t" else values
        del series
    t = out.pop("t")
    if t.size < MIN_ROWS:
        raise InputError(
            path,
            f"expected at least {MIN_ROWS} rows (time stamps) to estimate anything, got {t.size}",
            column="t",
        )
    if np.isnan(t).any():
        raise InputError(path, "expected a time stamp in every row", column="t", row=_first_row(np.isnan(t)))
    steps = np.diff(t)
    if (steps <= 0).any():
        i = int(np.argmax(steps <= 0))
        raise InputError(
            path,
            f"expected time stamps strictly increasing, got {float(t[i + 1])!r} s after {float(t[i])!r} s",
            column="t",
            row=i + 2,
        )
    for name in _DEFERRED:
        if name in deferred:
            raise deferred[name]
    out["t"] = t
    return out


def _column_values(name: str, series: pd.Series, path: str) -> np.ndarray:
    """One column as an array: a contract column as float64 (numbers, NaN, no inf), any other
    as read (integers and booleans as float)."""
    if name not in COLUMNS and name not in {c for k in GEODETIC for c in k}:
        arr = series.to_numpy()
        return arr.astype(float) if arr.dtype.kind in "iub" else arr
    if series.dtype.kind in "bmM":  # a reader's guess of true/false or dates: no number
        ok = series.notna().to_numpy()
        raise InputError(
            path,
            f"expected a number in {COLUMNS.get(name, 'deg or m')}, got "
            f"{_short(series[ok].iloc[0]) if ok.any() else 'no numbers'}",
            column=name,
            row=_first_row(ok) if ok.any() else None,
        )
    values = pd.to_numeric(series, errors="coerce").to_numpy(dtype=float)
    bad = np.isnan(values) & series.notna().to_numpy()
    if bad.any():
        row = _first_row(bad)
        raise InputError(
            path,
            f"expected a number in {COLUMNS.get(name, 'deg or m')}, got {_short(series.iloc[row - 1])}",
            column=name,
            row=row,
        )
    if np.isinf(values).any():
        raise InputError(
            path,
            "expected a finite number or an empty cell, got infinity",
            column=name,
            row=_first_row(np.isinf(values)),
        )
    return values


def _range_error(name: str, col: np.ndarray, path: str) -> InputError | None:
    """The evident-unit (:data:`LIMITS`) or negative-std error of one column, if any."""
    for names, limit, what in LIMITS:
        if name in names:
            over = np.abs(np.nan_to_num(col)) > limit
            if over.any():
                row = _first_row(over)
                return InputError(
                    path, f"value {col[row - 1]:g} is beyond {limit:g}: expected {what}", column=name, row=row
                )
    if name in ("gnss_pos_std", "gnss_vel_std"):
        negative = np.nan_to_num(col) < 0
        if negative.any():
            return InputError(
                path, "expected a standard deviation >= 0", column=name, row=_first_row(negative)
            )
    return None


def _geodetic_to_enu(cols: dict[str, np.ndarray], meta: dict[str, Any], path: str) -> None:
    for (la, lo, h), (e, n, u) in GEODETIC.items():
        if la not in cols or lo not in cols:
            continue
        lat, lon = cols[la], cols[lo]
        hgt = cols.get(h, np.zeros_like(lat))
        ok = np.isfinite(lat) & np.isfinite(lon)
        bad = ok & ((np.abs(lat) > 90) | (np.abs(lon) > 180))
        if bad.any():
            raise InputError(path, "expected latitude/longitude in degrees", column=la, row=_first_row(bad))
        if "origin" not in meta:
            if not ok.any():
                continue
            i = int(np.argmax(ok))
            meta["origin"] = [float(lat[i]), float(lon[i]), float(np.nan_to_num(hgt[i]))]
        enu = geodetic_to_enu(lat, lon, np.nan_to_num(hgt), tuple(meta["origin"]))
        for k, name in enumerate((e, n, u)):
            if name not in cols:
                cols[name] = np.where(ok, enu[:, k], np.nan)


# ------------------------------------------------------------------------------------------
# load / save
# ------------------------------------------------------------------------------------------
def load_drive(path: str | Path, compact: bool = False, reference: bool | None = None) -> Drive:
    """Load and validate a drive (CSV or Parquet by extension); geodetic columns -> ENU.

    ``compact``: the drive as :meth:`Drive.compact` gives it (sensor channels float32, and no
    ``ref_*`` columns unless ``reference=True``).  ``reference``: keep the ``ref_*`` truth
    columns (default: unless ``compact``); a Parquet file's are then not even read.  A Parquet
    file is read, checked and stored one column at a time, so the peak memory of a load is the
    drive's arrays plus one column, whatever the drive's length.
    """
    keep_reference = not compact if reference is None else reference
    store = _stored if compact else None
    p, src, suffix = _table_path(path)
    meta: dict[str, Any] = {}
    if suffix == ".csv":
        try:
            frame = _read_csv(p, src)
        except _READ_ERRORS as exc:
            raise _unreadable(src, suffix, exc) from None
        _read_sidecar(p, meta)
        cols = validate_frame(frame, src, store)
        del frame  # memory: the validated arrays are all that is kept
    else:
        names, columns = _parquet_columns(p, src, meta, keep_reference)
        _read_sidecar(p, meta)
        cols = validate_columns(names, columns, src, store)
        # arrow keeps the pages of the columns it decoded for reuse: hand them back, or they
        # stay resident under the methods (0.3 GB after a 24 h drive)
        pa.default_memory_pool().release_unused()
    _geodetic_to_enu(cols, meta, src)
    if not keep_reference:
        cols = {k: v for k, v in cols.items() if not k.startswith(REFERENCE_PREFIX)}
    t = cols.pop("t")
    return Drive(t=t, data=cols, meta=meta, path=src)


def save_drive(drive: Drive, path: str | Path) -> None:
    """Write a drive with its metadata (see :func:`save_table`)."""
    save_table(drive.to_frame(), path, dict(drive.meta))


def drive_from_columns(
    columns: Mapping[str, ArrayLike], meta: Mapping[str, Any] | None = None, path: str = "<memory>"
) -> Drive:
    """Build and validate a drive from in-memory columns (as the simulator and tests do)."""
    frame = pd.DataFrame({k: np.asarray(v) for k, v in columns.items()})
    cols = validate_frame(frame, path)
    m = dict(meta or {})
    _geodetic_to_enu(cols, m, path)
    t = cols.pop("t")
    return Drive(t=t, data=cols, meta=m, path=path)


ArrayLike = Any
