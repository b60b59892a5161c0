"""Methods registry: name -> function, the columns it needs, its vehicle parameters, its paper.

A method is a plain function ``f(drive, vehicle) -> Estimate``.  Modules in
``sideslip.methods`` register theirs with :func:`register`; :func:`all_methods` imports every
module of the package, so a new module needs no edit elsewhere.
"""

from __future__ import annotations

import importlib
import pkgutil
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from sideslip.drive import SPEED_COLUMNS, Drive
from sideslip.errors import InputError
from sideslip.estimate import Estimate, check_estimate
from sideslip.vehicle import Vehicle

MethodFunc = Callable[[Drive, Vehicle], Estimate]
SPEED = SPEED_COLUMNS  # "one of the wheel speeds or v_can"


@dataclass(frozen=True)
class Method:
    """A registered method.

    ``columns``: each entry is a column name, or a tuple of alternatives of which one suffices.
    ``vehicle_params``: vehicle parameters the method reads.
    """

    name: str
    func: MethodFunc
    columns: tuple[str | tuple[str, ...], ...]
    vehicle_params: tuple[str, ...]
    summary: str
    paper: str

    def columns_text(self) -> str:
        return ", ".join(c if isinstance(c, str) else "|".join(c) for c in self.columns)


_REGISTRY: dict[str, Method] = {}


def register(
    name: str,
    *,
    columns: Sequence[str | tuple[str, ...]],
    summary: str,
    paper: str,
    vehicle_params: Sequence[str] = (),
) -> Callable[[MethodFunc], MethodFunc]:
    """Decorator: register ``func`` under ``name`` (a lower-case identifier)."""
    if not name.isidentifier() or name != name.lower():
        raise ValueError(f"method name {name!r} must be a lower-case identifier")

    def deco(func: MethodFunc) -> MethodFunc:
        if name in _REGISTRY and _REGISTRY[name].func is not func:
            raise ValueError(f"method {name!r} registered twice")
        _REGISTRY[name] = Method(name, func, tuple(columns), tuple(vehicle_params), summary, paper)
        return func

    return deco


def all_methods() -> dict[str, Method]:
    """Every registered method, importing all modules of ``sideslip.methods`` first."""
    import sideslip.methods as pkg

    for info in pkgutil.iter_modules(pkg.__path__):
        if info.name != "registry" and not info.name.startswith("_"):
            importlib.import_module(f"sideslip.methods.{info.name}")
    return dict(sorted(_REGISTRY.items()))


def missing_columns(method: Method, drive: Drive) -> list[str]:
    """Column requirements of ``method`` that ``drive`` does not meet (as text)."""
    out = []
    for need in method.columns:
        alts = (need,) if isinstance(need, str) else need
        if not any(a in drive for a in alts):
            out.append(need if isinstance(need, str) else " or ".join(alts))
    return out


def why_not(method: Method, drive: Drive, vehicle: Vehicle) -> str | None:
    """The reason ``method`` cannot run on this drive/vehicle, or None when it can."""
    cols = missing_columns(method, drive)
    if cols:
        return "drive lacks " + ", ".join(f"'{c}'" for c in cols)
    params = vehicle.missing(list(method.vehicle_params))
    if params:
        return "vehicle file lacks " + ", ".join(f"'{p}'" for p in params)
    return None


def run_method(method: Method, drive: Drive, vehicle: Vehicle) -> Estimate:
    """Run one method after checking its needs; raises InputError naming what is missing."""
    cols = missing_columns(method, drive)
    if cols:
        raise InputError(
            drive.path,
            f"method '{method.name}' needs this column, which is missing or empty",
            column=cols[0],
        )
    params = vehicle.missing(list(method.vehicle_params))
    if params:
        raise InputError(
            vehicle.source,
            f"parameter '{params[0]}' is needed by method '{method.name}' "
            "but the vehicle file does not give it",
        )
    est = method.func(drive, vehicle)
    if est.method != method.name:
        est = Estimate(method.name, est.t, est.series, est.params)
    check_estimate(est, len(drive))
    if not np.array_equal(est.t, drive.t):
        raise RuntimeError(f"method {method.name}: estimate is not on the drive's time base")
    return est
