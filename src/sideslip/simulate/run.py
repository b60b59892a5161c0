"""The simulator's entry point: scenario -> truth -> sensor models -> validated :class:`Drive`.

``simulate("step_steer", seed=0)`` runs the scenario's truth model
(``sideslip.simulate.scenarios``) or, for names starting with ``cr_``, CommonRoad's multi-body
model (``sideslip.simulate.commonroad``), draws the sensor errors from a generator seeded by
``(seed, scenario)``, and builds the drive with the reference columns.
"""

from __future__ import annotations

import dataclasses
import importlib
import math
from typing import Any

import numpy as np

from sideslip.drive import Drive
from sideslip.errors import InputError
from sideslip.simulate import commonroad
from sideslip.simulate.assemble import SENSOR_STREAM, drive_from_truth, sensor_rng
from sideslip.simulate.sensors import SensorConfig
from sideslip.vehicle import Vehicle, load_vehicle

__all__ = ["DT", "SENSOR_STREAM", "describe", "drive_from_truth", "scenario_names", "sensor_rng", "simulate"]

DT = 0.01  # truth and table time step, s (100 Hz, the IMU rate)


def _scenarios() -> dict[str, Any]:
    """The truth-model scenarios (``sideslip.simulate.scenarios.SCENARIOS``)."""
    try:
        scenarios = importlib.import_module("sideslip.simulate.scenarios")
    except ModuleNotFoundError as exc:  # the truth model's module is not installed yet
        if exc.name != "sideslip.simulate.scenarios":
            raise
        return {}
    return dict(scenarios.SCENARIOS)


def scenario_names() -> list[str]:
    """Every scenario name :func:`simulate` accepts (CommonRoad ones when installed)."""
    names = list(_scenarios())
    if commonroad.available():
        names += list(commonroad.CR_SCENARIOS)
    return names


def describe(name: str) -> str:
    """One line about a scenario: description, vehicle, duration, paper."""
    scenario = _lookup(name)
    return (
        f"{scenario.description} (vehicle {scenario.vehicle}, {scenario.duration_s:g} s; "
        f"{scenario.paper})"
    )


def _lookup(name: str) -> Any:
    table = _scenarios()
    if name in table:
        return table[name]
    if name in commonroad.CR_SCENARIOS:
        return commonroad.CR_SCENARIOS[name]
    raise InputError(
        f"scenario '{name}'",
        "unknown scenario: expected one of " + ", ".join(scenario_names()),
    )


def _vehicle_ref(vehicle: Vehicle) -> str:
    """A name load_vehicle() maps back to ``vehicle``, else its source."""
    if vehicle.source.startswith("preset:"):
        name = vehicle.source.removeprefix("preset:")
        try:
            if load_vehicle(name) == vehicle:
                return name
        except InputError:
            pass
    return vehicle.source


def simulate(
    scenario: str,
    seed: int = 0,
    vehicle: Vehicle | None = None,
    config: SensorConfig | None = None,
    duration_s: float | None = None,
    tyre_relaxation_m: float = 0.0,
) -> Drive:
    """Simulate a scenario and return a validated 100 Hz drive with reference columns.

    scenario  a name from :func:`scenario_names` (unknown: InputError listing the valid ones)
    seed      non-negative int; drives the truth's randomness (driver, road) and, through
              :func:`sensor_rng`, the sensor errors
    vehicle   the simulated car (default: the scenario's preset); not accepted for the
              ``cr_`` scenarios, whose car is CommonRoad's parameter set
    config    sensor grades (default: ``SensorConfig()`` with the scenario's
              ``sensor_overrides``); when given it is used as is
    duration_s  optional length of the drive, s (default: the scenario's); not for ``cr_``
    tyre_relaxation_m  the truth's tyre relaxation length, m (default 0: each tyre's force
              follows its slip at once, as every table in benchmarks/results was made; real
              passenger-car tyres take 0.5-1.5 m, Pacejka 2012 sec. 7.2); not for ``cr_``

    ``drive.meta``: ``scenario``, ``seed``, ``vehicle`` (preset name, or the vehicle's source
    when it is not an unmodified preset), ``vehicle_params``, ``source``, ``truth_sensor``
    (the true sensor errors drawn: gyro_bias, gyro_scale_factor, accel_bias,
    wheel_scale_factor, steer_offset, steer_scale_factor, ...), ``sensor_config``; and
    ``tyre_relaxation_m`` where it is not 0.
    """
    spec = _lookup(scenario)
    if isinstance(seed, bool) or not isinstance(seed, int | np.integer) or seed < 0:
        raise InputError(f"scenario '{scenario}'", f"seed {seed!r}: expected an integer >= 0")
    cfg = config if config is not None else SensorConfig().with_overrides(spec.sensor_overrides)
    relaxation = float(tyre_relaxation_m)
    if not (math.isfinite(relaxation) and 0.0 <= relaxation <= 5.0):
        raise InputError(
            f"scenario '{scenario}'", f"tyre relaxation {tyre_relaxation_m!r} m: expected 0 to 5"
        )
    if scenario in commonroad.CR_SCENARIOS:
        if relaxation:
            raise InputError(
                f"scenario '{scenario}'",
                "the CommonRoad scenarios run CommonRoad's own tyre model; expected no tyre relaxation",
            )
        if vehicle is not None:
            raise InputError(
                f"scenario '{scenario}'",
                "the CommonRoad scenarios simulate CommonRoad's own car "
                f"({spec.vehicle}); expected no vehicle",
            )
        commonroad._require()
        truth = commonroad.scenario_truth(scenario, DT)
        return commonroad.commonroad_drive(truth, spec.params, int(seed), cfg, scenario)
    from sideslip.simulate import scenarios

    car = vehicle if vehicle is not None else load_vehicle(spec.vehicle)
    if duration_s is not None and not 1.0 <= float(duration_s) <= 6.0 * 3600.0:
        raise InputError(f"scenario '{scenario}'", f"duration {duration_s!r} s: expected 1 to 21600 s")
    truth = scenarios.run_scenario(
        scenario, seed=int(seed), vehicle=car, dt=DT, duration_s=duration_s, relaxation_m=relaxation
    )
    ref = spec.vehicle if vehicle is None else _vehicle_ref(vehicle)
    drive = drive_from_truth(truth, car, int(seed), cfg, scenario, ref)
    if relaxation:
        drive = dataclasses.replace(drive, meta={**drive.meta, "tyre_relaxation_m": relaxation})
    return drive
