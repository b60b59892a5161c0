"""The public Python API, re-exported by ``import sideslip as ss`` (lazily, see ``__init__``).

::

    import sideslip as ss
    drive = ss.load_drive("drive.parquet")            # or ss.simulate_drive("dlc_bank", seed=1)
    est = ss.estimate(drive, "midsize_sedan", methods=["fused", "fg_batch"])
    est.to_frame()                                     # t, fused.beta, fused.beta_std, ...
    ss.evaluate(drive, est)                            # method -> metric -> value

Methods are named, given as registered :class:`~sideslip.methods.registry.Method` objects, or
as plain functions ``f(drive, vehicle) -> Estimate`` (registered or not).  A vehicle is a
:class:`~sideslip.vehicle.Vehicle`, a preset name or a TOML path.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from sideslip.drive import Drive
from sideslip.errors import InputError
from sideslip.estimate import Estimate, Estimates, check_estimate
from sideslip.vehicle import Vehicle

MethodLike = Any  # a method name, a registered Method, or a function (drive, vehicle) -> Estimate
# progress callback: (event "start" | "done" | "skip", method name, index, total, detail)
Progress = Callable[[str, str, int, int, str], None]


def load_drive(path: str | Path) -> Drive:
    """A validated drive from a CSV or Parquet table (contract section 1)."""
    from sideslip.drive import load_drive as _load

    return _load(path)


def load_vehicle(vehicle: Vehicle | str | Path) -> Vehicle:
    """A vehicle from a preset name or a TOML path (a :class:`Vehicle` is returned as is)."""
    from sideslip.vehicle import load_vehicle as _load

    return vehicle if isinstance(vehicle, Vehicle) else _load(str(vehicle))


def simulate_drive(scenario: str, seed: int = 0, vehicle: Vehicle | str | Path | None = None) -> Drive:
    """A simulated drive with reference columns (see ``sideslip scenarios``)."""
    import sideslip.simulate as sim

    return sim.simulate(scenario, seed=seed, vehicle=None if vehicle is None else load_vehicle(vehicle))


def method_names() -> list[str]:
    """Names of every registered method."""
    from sideslip.methods.registry import all_methods

    return list(all_methods())


def _as_drive(drive: Drive | str | Path) -> Drive:
    return drive if isinstance(drive, Drive) else load_drive(drive)


def _resolve(method: MethodLike) -> tuple[str, Any]:
    """(name, registered Method or plain function) for one entry of ``methods``."""
    from sideslip.methods.registry import Method, all_methods, get_method

    if isinstance(method, str | Method):
        m = get_method(method)
        return m.name, m
    if callable(method):
        for m in all_methods().values():
            if m.func is method:
                return m.name, m
        return str(getattr(method, "__name__", "custom")), method
    raise TypeError(f"a method must be a name, a Method or a function, not {type(method).__name__}")


def _run_plain(func: Callable[..., Estimate], name: str, drive: Drive, vehicle: Vehicle) -> Estimate:
    est = func(drive, vehicle)
    if not isinstance(est, Estimate):
        raise TypeError(f"method {name} returned {type(est).__name__}, expected an Estimate")
    if not est.method:
        est = Estimate(name, est.t, est.series, est.params, est.innovations)
    check_estimate(est, len(drive))
    if not np.array_equal(est.t, drive.t):
        raise RuntimeError(f"method {est.method}: estimate is not on the drive's time base")
    return est


def estimate(
    drive: Drive | str | Path,
    vehicle: Vehicle | str | Path,
    methods: Sequence[MethodLike] | None = None,
    settings: Mapping[str, Any] | None = None,
    progress: Progress | None = None,
) -> Estimates:
    """Run methods on a drive; returns :class:`~sideslip.estimate.Estimates`.

    ``methods``: names, Method objects or functions; None runs every registered method the
    drive's columns and the vehicle file allow, and lists the others with their reason in
    ``Estimates.skipped``.  A method named explicitly that cannot run raises the
    :class:`~sideslip.errors.InputError` naming the missing column or parameter.
    ``settings``: method name -> settings object or ``{field: value}`` (see
    :mod:`sideslip.settings`).  ``progress``: called as ``progress(event, name, i, n, detail)``
    with ``event`` "start", "done" (detail: seconds) or "skip" (detail: the reason).
    """
    from sideslip.methods.registry import Method, all_methods, check_method, run_method, why_not

    d = _as_drive(drive)
    veh = load_vehicle(vehicle)
    settings = dict(settings or {})
    explicit = methods is not None
    chosen = [_resolve(m) for m in methods] if methods is not None else list(all_methods().items())
    for name in settings:
        if name not in [n for n, _ in chosen]:
            raise InputError("settings", f"settings for method '{name}', which is not run")
    done: list[Estimate] = []
    skipped: dict[str, str] = {}
    total = len(chosen)
    # every method that will run is checked before the first runs: a bad input stops the run
    # with its one line before any method has spent time on it (contract section 5)
    resolved: dict[str, Any] = {}
    for name, m in chosen:
        if isinstance(m, Method) and (explicit or why_not(m, d, veh) is None):
            resolved[name] = check_method(m, d, veh, settings.get(name))  # the precise one line
    for i, (name, m) in enumerate(chosen):
        if isinstance(m, Method) and name not in resolved:
            reason = why_not(m, d, veh) or ""
            skipped[name] = reason
            if progress:
                progress("skip", name, i, total, reason)
            continue
        if progress:
            progress("start", name, i, total, "")
        start = time.perf_counter()
        if isinstance(m, Method):
            est = run_method(m, d, veh, resolved[name], checked=True)
        else:
            est = _run_plain(m, name, d, veh)
        done.append(est)
        if progress:
            progress("done", name, i, total, f"{time.perf_counter() - start:.2f}")
    return Estimates(d.t, tuple(done), skipped)


def evaluate(
    drive: Drive | str | Path,
    estimates: Estimates | Estimate | Mapping[str, Mapping[str, Any]],
    windows: Sequence[tuple[float, float]] = (),
) -> dict[str, dict[str, float]]:
    """Method -> metric -> value against the drive's reference columns (contract section 4).

    ``estimates``: what :func:`estimate` returns, one :class:`Estimate`, or the layout of
    :func:`~sideslip.estimate.load_estimates`.  ``windows``: (t0, t1) pairs in s; every metric
    is then computed on the rows inside them only (see :mod:`sideslip.windows`).
    """
    from sideslip.evaluate import Window
    from sideslip.windows import evaluate_windows

    d = _as_drive(drive)
    if isinstance(estimates, Estimates):
        series: Mapping[str, Mapping[str, Any]] = estimates.series()
    elif isinstance(estimates, Estimate):
        series = {estimates.method: dict(estimates.series)}
    else:
        series = estimates
    wins = [w if isinstance(w, Window) else Window(float(w[0]), float(w[1])) for w in windows]
    return evaluate_windows(d, series, wins)
