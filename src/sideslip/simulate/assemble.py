"""A drive from a truth: the sensor models' columns, the metadata, validation.

Shared by the scenario runner (:mod:`sideslip.simulate.run`) and the CommonRoad truth
(:mod:`sideslip.simulate.commonroad`); it imports neither, so the two need not import each other.
"""

from __future__ import annotations

import zlib
from dataclasses import fields
from typing import Any

import numpy as np

from sideslip.drive import Drive, drive_from_columns
from sideslip.simulate.sensors import SensorConfig, sensor_columns
from sideslip.simulate.truth import Truth
from sideslip.vehicle import Vehicle

SENSOR_STREAM = 0x5E5
"""Entropy word that separates the sensor-error stream from the truth model's stream."""


def sensor_rng(seed: int, scenario: str) -> np.random.Generator:
    """The generator the sensor errors of ``(seed, scenario)`` are drawn from."""
    return np.random.default_rng([int(seed), zlib.crc32(scenario.encode()), SENSOR_STREAM])


def _vehicle_params(vehicle: Vehicle) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for f in fields(vehicle):
        value = getattr(vehicle, f.name)
        out[f.name] = list(value) if isinstance(value, tuple) else value
    out["understeer_gradient"] = vehicle.understeer_gradient
    return {k: (None if isinstance(v, float) and not np.isfinite(v) else v) for k, v in out.items()}


def drive_from_truth(
    truth: Truth,
    vehicle: Vehicle,
    seed: int = 0,
    config: SensorConfig | None = None,
    scenario: str = "custom",
    vehicle_ref: str | None = None,
    source: str = "sideslip simulator",
) -> Drive:
    """Run the sensor models on ``truth`` and build a validated drive.

    ``vehicle`` gives the lever arms; ``vehicle_ref`` is what ``meta["vehicle"]`` says (a
    preset name or path that :func:`~sideslip.vehicle.load_vehicle` accepts; default
    ``vehicle.source``).  ``meta["vehicle_params"]`` always carries the true parameters.
    """
    cfg = config if config is not None else SensorConfig()
    cols, truth_sensor = sensor_columns(truth, vehicle, cfg, sensor_rng(seed, scenario))
    meta = {
        "scenario": scenario,
        "seed": int(seed),
        "vehicle": vehicle_ref if vehicle_ref is not None else vehicle.source,
        "vehicle_params": _vehicle_params(vehicle),
        "source": source,
        "truth_sensor": truth_sensor,
        "sensor_config": cfg.as_dict(),
    }
    return drive_from_columns(cols, meta, path=f"<simulated {scenario}>")
