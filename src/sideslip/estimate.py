"""What every method returns, and the output table of contract section 3."""

from __future__ import annotations

import json
import math
from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from sideslip.drive import _atomic_write
from sideslip.tables import save_columns

FloatArray = NDArray[np.float64]

# Series names of the contract (section 3); methods may add others (e.g. 'yaw_std', 'e_std').
CONTRACT_SERIES = (
    "beta", "r", "yaw", "roll", "bank", "e", "n", "vx", "vy", "gyro_bias", "ay_bias", "beta_std",
)  # fmt: skip


@dataclass(frozen=True)
class Estimate:
    """A method's result on a drive's time base.

    ``series`` maps names such as ``beta`` (rad, at the CG), ``r`` (rad/s), ``yaw``, ``roll``,
    ``bank`` (rad), ``e``/``n`` (m, ENU), ``vx``/``vy`` (m/s), ``gyro_bias`` (rad/s), ``ay_bias``
    (m/s^2), 1-sigma series ``<name>_std`` and ``health`` (0 good ... 1 unusable) to arrays as
    long as ``t``.  ``params`` holds identified parameters and diagnostics (JSON-serialisable:
    numbers, strings, lists, dicts).  ``innovations`` maps a measurement name to per-row arrays
    of what a filter saw, e.g. ``"course"`` (innovation, rad; NaN where no update) and
    ``"course_nis"`` (normalised innovation squared); they are kept in memory for diagnostics
    and tests, not written to the contract table.
    """

    method: str
    t: FloatArray
    series: Mapping[str, FloatArray]
    params: Mapping[str, Any] = field(default_factory=dict)
    innovations: Mapping[str, FloatArray] = field(default_factory=dict)

    def __getitem__(self, name: str) -> FloatArray:
        return self.series[name]

    def to_frame(self, prefix: bool = False) -> pd.DataFrame:
        """The series as a table: ``t`` and one column per series (``M.beta`` with ``prefix``)."""
        return estimates_frame(self.t, [self]) if prefix else pd.DataFrame(
            {"t": self.t, **{k: np.asarray(v, dtype=float) for k, v in self.series.items()}}
        )


SKIPPED_KEY = "_skipped"  # params JSON entry: method -> why it did not run


@dataclass(frozen=True)
class Estimates:
    """The result of :func:`sideslip.estimate`: the estimates that ran, and why others did not.

    ``est["fused"]`` is one :class:`Estimate`; iteration yields them in run order;
    :meth:`to_frame` is the contract's output table (``t``, ``M.beta``, ...); ``skipped`` maps
    a method name to the reason it could not run on this drive and vehicle.
    """

    t: FloatArray
    estimates: tuple[Estimate, ...]
    skipped: Mapping[str, str] = field(default_factory=dict)

    def __getitem__(self, method: str) -> Estimate:
        for est in self.estimates:
            if est.method == method:
                return est
        raise KeyError(f"no estimate of method {method!r}: ran {', '.join(self.names) or 'none'}")

    def __iter__(self) -> Iterator[Estimate]:
        return iter(self.estimates)

    def __len__(self) -> int:
        return len(self.estimates)

    def __contains__(self, method: object) -> bool:
        return method in self.names

    @property
    def names(self) -> list[str]:
        """Methods that ran, in run order."""
        return [e.method for e in self.estimates]

    @property
    def params(self) -> dict[str, Any]:
        """Method -> identified parameters and diagnostics (as in the params JSON)."""
        return {e.method: dict(e.params) for e in self.estimates}

    def series(self) -> dict[str, dict[str, FloatArray]]:
        """Method -> series name -> array (the layout :func:`load_estimates` returns)."""
        return {"": {"t": self.t}, **{e.method: dict(e.series) for e in self.estimates}}

    def to_frame(self) -> pd.DataFrame:
        """The contract's output table: ``t`` and ``M.<series>`` for each method M."""
        return estimates_frame(self.t, self.estimates)

    def save(self, path: str | Path, meta: Mapping[str, Any] | None = None) -> Path:
        """Write the table and its ``.params.json`` (as ``sideslip estimate``); returns the JSON."""
        return save_estimates(self.t, self.estimates, path, meta, self.skipped)


def check_estimate(est: Estimate, n: int) -> None:
    """Fail loudly (a bug, not a user error) if a method broke the output promise."""
    for name, values in est.series.items():
        arr = np.asarray(values)
        if arr.shape != (n,):
            raise RuntimeError(f"method {est.method}: series '{name}' has shape {arr.shape}, not ({n},)")
        if not np.isfinite(arr).all():
            row = int(np.argmax(~np.isfinite(arr))) + 1
            raise RuntimeError(f"method {est.method}: series '{name}' is not finite at row {row}")


def _jsonable(value: Any) -> Any:
    if isinstance(value, Mapping):
        return {str(k): _jsonable(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_jsonable(v) for v in value]
    if isinstance(value, np.ndarray):
        return _jsonable(value.tolist())
    if isinstance(value, np.generic):
        return _jsonable(value.item())
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value


def estimates_frame(t: FloatArray, estimates: Sequence[Estimate]) -> pd.DataFrame:
    """One table: ``t`` and ``M.<series>`` for each method M (contract section 3)."""
    cols: dict[str, FloatArray] = {"t": t}
    for est in estimates:
        for name, values in est.series.items():
            cols[f"{est.method}.{name}"] = np.asarray(values, dtype=float)
    return pd.DataFrame(cols)


def params_path(table_path: Path) -> Path:
    """Identified parameters beside the table: ``est.parquet`` -> ``est.params.json``."""
    return table_path.with_name(table_path.stem + ".params.json")


def save_estimates(
    t: FloatArray,
    estimates: Sequence[Estimate],
    path: str | Path,
    meta: Mapping[str, Any] | None = None,
    skipped: Mapping[str, str] | None = None,
) -> Path:
    """Write the estimate table and its parameter JSON; returns the JSON path.

    ``skipped`` (method -> reason it did not run) goes to the JSON under ``"_skipped"`` so the
    report can list it; every other key of the JSON is a method name.
    """
    p = Path(path)
    cols: dict[str, Any] = {"t": t}
    for est in estimates:
        cols.update({f"{est.method}.{name}": values for name, values in est.series.items()})
    params: dict[str, Any] = {est.method: _jsonable(dict(est.params)) for est in estimates}
    if skipped:
        params[SKIPPED_KEY] = dict(skipped)
    save_columns(cols, p, meta)  # in slices of rows: no whole-table copy of a long drive
    jp = params_path(p)
    _atomic_write(jp, lambda tmp: tmp.write_text(json.dumps(params, indent=2)))
    return jp


def load_estimates(path: str | Path) -> dict[str, dict[str, FloatArray]]:
    """Read an estimate table back as method -> series -> array (plus '' -> {'t': t})."""
    from sideslip.errors import InputError
    from sideslip.tables import read_table

    frame, _ = read_table(path)
    if "t" not in frame.columns:
        raise InputError(str(path), "required column is missing: expected time stamps in s", column="t")
    out: dict[str, dict[str, FloatArray]] = {"": {"t": frame["t"].to_numpy(dtype=float)}}
    for col in frame.columns:
        if "." not in str(col):
            continue
        method, name = str(col).split(".", 1)
        values = pd.to_numeric(frame[col], errors="coerce").to_numpy(dtype=float)
        out.setdefault(method, {})[name] = values
    return out


from sideslip._callable import make_callable  # noqa: E402  (last: the module must exist)

make_callable(__name__, "sideslip.api:estimate")  # sideslip.estimate(drive, vehicle, methods)
