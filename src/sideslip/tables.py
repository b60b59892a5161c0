"""Tables on disk: CSV and Parquet read and written whole or a column / a block of rows at a
time, with their metadata (Parquet key-value ``sideslip``, or a ``<stem>.meta.json`` side-car),
and the checks that belong to the file rather than to a drive (names given twice, cells too
long to be values).  Unreadable files raise :class:`~sideslip.errors.InputError`; writes go
through :func:`~sideslip.outputs.atomic_write`, so nothing is ever half-written.
"""

from __future__ import annotations

import csv
import json
import re
from collections.abc import Iterator, Mapping
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq

from sideslip.errors import InputError
from sideslip.outputs import atomic_write, output_group

# Longest cell accepted in a table (characters): a longer one is a broken file (a missing line
# break or closing quote swallowed the rows after it), not a value.
MAX_CELL_CHARS = 1 << 20
REFERENCE_PREFIX = "ref_"  # truth columns: for evaluation, never read by a method
ArrayLike = Any


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
            raise InputError(
                path, "appears twice: expected each column once (which one holds the data?)", column=name
            )
        seen.add(name)


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


_READ_ERRORS = (OSError, ValueError, pa.ArrowException, json.JSONDecodeError, UnicodeDecodeError)


def _unreadable(src: str, suffix: str, exc: BaseException) -> InputError:
    first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
    return InputError(src, f"cannot read as {suffix[1:]}: {first[:200]}")


def _table_path(path: str | Path) -> tuple[Path, str, str]:
    """(path, its name for messages, lower-case suffix) of a table that exists."""
    p = Path(path)
    src = str(path)
    suffix = p.suffix.lower()
    if suffix not in (".csv", ".parquet", ".pq"):
        raise InputError(src, "expected a .csv or .parquet file")
    if not p.is_file():
        raise InputError(src, "cannot read: no such file")
    return p, src, suffix


def _read_sidecar(p: Path, meta: dict[str, Any]) -> None:
    """Merge the side-car ``<stem>.meta.json`` (if any) into ``meta``."""
    side = meta_path(p)
    if side.is_file():
        try:
            extra = json.loads(side.read_text())
        except (OSError, json.JSONDecodeError, UnicodeDecodeError) as exc:
            raise InputError(str(side), f"expected JSON metadata ({str(exc)[:200]})") from None
        if not isinstance(extra, dict):
            raise InputError(str(side), "expected a JSON object of metadata")
        meta.update(extra)


def read_table(path: str | Path, reference: bool = True) -> tuple[pd.DataFrame, dict[str, Any]]:
    """Read a CSV or Parquet table and its metadata; unreadable files raise InputError.

    Columns named twice and cells too long to be values (:data:`MAX_CELL_CHARS`) are errors
    naming the column (and row).  ``reference=False`` skips a Parquet file's ``ref_*``
    columns (a CSV is read whole).
    """
    p, src, suffix = _table_path(path)
    meta: dict[str, Any] = {}
    try:
        frame = _read_csv(p, src) if suffix == ".csv" else _read_parquet(p, src, meta, reference)
    except _READ_ERRORS as exc:
        raise _unreadable(src, suffix, exc) from None
    _read_sidecar(p, meta)
    return frame, meta


def table_rows(path: str | Path) -> int | None:
    """Rows of a Parquet table from its footer (no data read); None for a CSV or a file that
    cannot be read (loading it then names the problem)."""
    if Path(path).suffix.lower() not in (".parquet", ".pq"):
        return None
    try:
        return int(pq.ParquetFile(path).metadata.num_rows)
    except _READ_ERRORS:
        return None


def _parquet_columns(
    p: Path, src: str, meta: dict[str, Any], reference: bool
) -> tuple[list[str], Iterator[tuple[str, pd.Series]]]:
    """A Parquet file's column names and a reader yielding its columns one at a time."""
    try:
        parquet = pq.ParquetFile(p)
        schema = parquet.schema_arrow
        kv = schema.metadata or {}
        if b"sideslip" in kv:
            meta.update(json.loads(kv[b"sideslip"]))
    except _READ_ERRORS as exc:
        raise _unreadable(src, ".parquet", exc) from None
    names = [str(n) for n in schema.names]
    _check_names(names, src)
    keep = [n for n in names if reference or not n.startswith(REFERENCE_PREFIX)]

    def columns() -> Iterator[tuple[str, pd.Series]]:
        for name in keep:
            try:
                series = parquet.read(columns=[name]).column(0).to_pandas()
            except _READ_ERRORS as exc:
                raise _unreadable(src, ".parquet", exc) from None
            _check_cells(series.to_frame(name), src)
            yield name, series

    return keep, columns()


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


# Rows written at a time by :func:`save_columns` (one Parquet row group, one CSV block).
WRITE_CHUNK_ROWS = 1 << 20


def save_columns(
    columns: Mapping[str, ArrayLike], path: str | Path, meta: Mapping[str, Any] | None = None
) -> None:
    """:func:`save_table` for numeric columns of one length, written in slices of
    :data:`WRITE_CHUNK_ROWS` rows: besides the arrays themselves, only one slice is ever held
    as a table (a day-long estimate is written without a second copy of it in memory).  Every
    column is written as float64; the file reads back as :func:`save_table`'s would."""
    p = Path(path)
    suffix = p.suffix.lower()
    if suffix not in (".csv", ".parquet", ".pq"):
        raise InputError(str(path), "expected an output path ending in .csv or .parquet")
    meta = dict(meta or {})
    n = len(next(iter(columns.values()))) if columns else 0
    starts = range(0, max(n, 1), WRITE_CHUNK_ROWS)

    def block(start: int) -> dict[str, np.ndarray]:
        return {k: np.asarray(v[start : start + WRITE_CHUNK_ROWS], dtype=float) for k, v in columns.items()}

    def write_csv(tmp: Path) -> None:
        with open(tmp, "w", newline="") as fh:
            for i, start in enumerate(starts):
                pd.DataFrame(block(start)).to_csv(fh, index=False, header=i == 0, float_format="%.10g")

    def write_parquet(tmp: Path) -> None:
        schema = pa.schema(
            [(k, pa.float64()) for k in columns], metadata={b"sideslip": json.dumps(meta).encode()}
        )
        with pq.ParquetWriter(tmp, schema) as writer:
            for start in starts:
                writer.write_table(pa.table(block(start), schema=schema))

    if suffix == ".csv":
        with output_group():  # the table and its side-car appear together, or neither
            atomic_write(p, write_csv)
            if meta:
                atomic_write(meta_path(p), lambda tmp: tmp.write_text(json.dumps(meta, indent=2)))
    else:
        atomic_write(p, write_parquet)
