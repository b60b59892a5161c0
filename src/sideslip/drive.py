"""A drive (contract section 1): columns on one time base, validation (section 5), load/save.

Rows are numbered from 1 for the first data row (the CSV header is not a row), so "row 12" is
the 12th sample of the table in both CSV and Parquet.
"""

from __future__ import annotations

import csv
import json
import re
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq
from numpy.typing import NDArray

from sideslip.errors import InputError
from sideslip.frames import geodetic_to_enu
from sideslip.outputs import atomic_write, output_group

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
REFERENCE_PREFIX = "ref_"  # truth columns: for evaluation, never read by a method
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
# Longest cell accepted in a table (characters): a longer one is a broken file (a missing line
# break or closing quote swallowed the rows after it), not a value.
MAX_CELL_CHARS = 1 << 20

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
def _first_row(mask: np.ndarray) -> int:
    return int(np.argmax(mask)) + 1


def _short(value: Any, limit: int = 40) -> str:
    """``repr`` of a cell for a one-line message, cut to ``limit`` characters."""
    text = repr(value)
    if len(text) > limit:
        text = f"{text[: limit - 12]}... ({len(str(value)):,} characters)"
    return text.replace("\n", " ")


def _check_names(names: list[str], path: str) -> None:
    seen: set[str] = set()
    for name in names:
        if name in seen:
            raise InputError(path, "appears twice: expected each column once (which one holds the "
                             "data?)", column=name)
        seen.add(name)


def validate_frame(frame: pd.DataFrame, path: str) -> dict[str, np.ndarray]:
    """Apply contract section 5 to a table; return its columns as arrays.

    Raises :class:`InputError` on the first violated rule, naming file, column, row and what
    was expected.
    """
    _check_names([str(c) for c in frame.columns], path)
    if "t" not in frame.columns:
        raise InputError(path, "required column is missing: expected time stamps in s", column="t")
    out: dict[str, np.ndarray] = {}
    for name in frame.columns:
        name_s = str(name)
        series = frame[name]
        if name_s in COLUMNS or name_s in {c for k in GEODETIC for c in k}:
            if series.dtype.kind in "bmM":  # a reader's guess of true/false or dates: no number
                ok = series.notna().to_numpy()
                raise InputError(
                    path,
                    f"expected a number in {COLUMNS.get(name_s, 'deg or m')}, got "
                    f"{_short(series[ok].iloc[0]) if ok.any() else 'no numbers'}",
                    column=name_s,
                    row=_first_row(ok) if ok.any() else None,
                )
            values = pd.to_numeric(series, errors="coerce").to_numpy(dtype=float)
            bad = np.isnan(values) & series.notna().to_numpy()
            if bad.any():
                row = _first_row(bad)
                raise InputError(
                    path,
                    f"expected a number in {COLUMNS.get(name_s, 'deg or m')}, got "
                    f"{_short(series.iloc[row - 1])}",
                    column=name_s,
                    row=row,
                )
            if np.isinf(values).any():
                raise InputError(
                    path,
                    "expected a finite number or an empty cell, got infinity",
                    column=name_s,
                    row=_first_row(np.isinf(values)),
                )
            out[name_s] = values
        else:
            arr = series.to_numpy()
            if arr.dtype.kind in "iub":
                arr = arr.astype(float)
            out[name_s] = arr
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
            f"expected time stamps strictly increasing, got {t[i + 1]!r} after {t[i]!r}",
            column="t",
            row=i + 2,
        )
    for names, limit, what in LIMITS:
        for name in names:
            col = out.get(name)
            if col is None:
                continue
            over = np.abs(np.nan_to_num(col)) > limit
            if over.any():
                row = _first_row(over)
                raise InputError(
                    path,
                    f"value {col[row - 1]:g} is beyond {limit:g}: expected {what}",
                    column=name,
                    row=row,
                )
    for name in ("gnss_pos_std", "gnss_vel_std"):
        col = out.get(name)
        if col is not None and (np.nan_to_num(col) < 0).any():
            raise InputError(
                path,
                "expected a standard deviation >= 0",
                column=name,
                row=_first_row(np.nan_to_num(col) < 0),
            )
    out["t"] = t
    return out


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
def meta_path(path: Path) -> Path:
    """Side-car metadata file of a drive table: ``drive.csv`` -> ``drive.meta.json``."""
    return path.with_name(path.stem + ".meta.json")


def _csv_header(p: Path) -> list[str]:
    """The column names exactly as the CSV's first line spells them (readers rename repeats)."""
    with open(p, encoding="utf-8", errors="replace", newline="") as fh:
        line = fh.readline(MAX_CELL_CHARS)
    try:
        return next(csv.reader([line]), [])
    except csv.Error:
        return []


def _check_cells(frame: pd.DataFrame, src: str) -> None:
    """A text cell longer than :data:`MAX_CELL_CHARS` is a broken file: name its row."""
    for name in frame.columns:
        col = frame[name]
        if col.dtype.kind in "fiubmM":  # numbers and times: no text to measure
            continue
        lengths = col.map(lambda v: len(v) if isinstance(v, str) else 0).to_numpy()
        over = lengths > MAX_CELL_CHARS
        if over.any():
            row = _first_row(over)
            raise InputError(
                src,
                f"a cell of {int(lengths[row - 1]):,} characters: expected a value (a missing line "
                "break or closing quote?)",
                column=str(name),
                row=row,
            )


def _read_csv(p: Path, src: str) -> pd.DataFrame:
    if not p.stat().st_size:
        return pd.DataFrame()
    _check_names(_csv_header(p), src)
    try:
        frame = pd.read_csv(p, engine="pyarrow")
    except (ValueError, pa.ArrowException):
        # pyarrow's fast reader names no row (e.g. a cell longer than its block): read again
        # with pandas' own parser, which names the line of a malformed row.
        try:
            frame = pd.read_csv(p, engine="c", low_memory=False)
        except (ValueError, UnicodeDecodeError) as exc:
            text = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
            line = re.search(r"in line (\d+)", text)
            if line:  # pandas counts file lines from 1 with the header; rows start after it
                raise InputError(src, f"cannot read as csv: {text}", row=int(line.group(1)) - 1) from None
            raise
    _check_cells(frame, src)
    return frame


def _read_parquet(p: Path, src: str, meta: dict[str, Any], reference: bool = True) -> pd.DataFrame:
    names = [str(n) for n in pq.read_schema(p).names]
    _check_names(names, src)
    keep = None if reference else [n for n in names if not n.startswith(REFERENCE_PREFIX)]
    table = pq.ParquetFile(p).read(columns=keep)
    kv = table.schema.metadata or {}
    if b"sideslip" in kv:
        meta.update(json.loads(kv[b"sideslip"]))
    frame = table.to_pandas()
    _check_cells(frame, src)
    return frame


def read_table(path: str | Path, reference: bool = True) -> tuple[pd.DataFrame, dict[str, Any]]:
    """Read a CSV or Parquet table and its metadata; unreadable files raise InputError.

    Columns named twice and cells too long to be values (:data:`MAX_CELL_CHARS`) are errors
    naming the column (and row).  ``reference=False`` skips a Parquet file's ``ref_*``
    columns (a CSV is read whole).
    """
    p = Path(path)
    src = str(path)
    suffix = p.suffix.lower()
    if suffix not in (".csv", ".parquet", ".pq"):
        raise InputError(src, "expected a .csv or .parquet file")
    if not p.is_file():
        raise InputError(src, "cannot read: no such file")
    meta: dict[str, Any] = {}
    try:
        frame = _read_csv(p, src) if suffix == ".csv" else _read_parquet(p, src, meta, reference)
    except (OSError, ValueError, pa.ArrowException, json.JSONDecodeError, UnicodeDecodeError) as exc:
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise InputError(src, f"cannot read as {suffix[1:]}: {first[:200]}") from None
    side = meta_path(p)
    if side.is_file():
        try:
            extra = json.loads(side.read_text())
        except (OSError, json.JSONDecodeError, UnicodeDecodeError) as exc:
            raise InputError(str(side), f"expected JSON metadata ({str(exc)[:200]})") from None
        if not isinstance(extra, dict):
            raise InputError(str(side), "expected a JSON object of metadata")
        meta.update(extra)
    return frame, meta


def load_drive(path: str | Path, compact: bool = False) -> Drive:
    """Load and validate a drive (CSV or Parquet by extension); geodetic columns -> ENU.

    ``compact``: return :meth:`Drive.compact` (what the methods need: no ``ref_*`` columns,
    sensor channels float32); a Parquet file's reference columns are then not even read.
    """
    frame, meta = read_table(path, reference=not compact)
    cols = validate_frame(frame, str(path))
    del frame  # memory: the validated arrays are all that is kept
    _geodetic_to_enu(cols, meta, str(path))
    t = cols.pop("t")
    drive = Drive(t=t, data=cols, meta=meta, path=str(path))
    return drive.compact() if compact else drive


def save_table(frame: pd.DataFrame, path: str | Path, meta: Mapping[str, Any] | None = None) -> None:
    """Write a table (CSV or Parquet by extension) atomically: never half-written.

    Parquet carries ``meta`` as key-value metadata under ``sideslip``; CSV gets a side-car
    ``<stem>.meta.json``.
    """
    p = Path(path)
    suffix = p.suffix.lower()
    if suffix not in (".csv", ".parquet", ".pq"):
        raise InputError(str(path), "expected an output path ending in .csv or .parquet")
    meta = dict(meta or {})
    if suffix == ".csv":
        with output_group():  # the table and its side-car appear together, or neither
            atomic_write(p, lambda tmp: frame.to_csv(tmp, index=False, float_format="%.10g"))
            if meta:
                atomic_write(meta_path(p), lambda tmp: tmp.write_text(json.dumps(meta, indent=2)))
    else:
        table = pa.Table.from_pandas(frame, preserve_index=False)
        kv = dict(table.schema.metadata or {})
        kv[b"sideslip"] = json.dumps(meta).encode()
        table = table.replace_schema_metadata(kv)
        atomic_write(p, lambda tmp: pq.write_table(table, tmp))


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
