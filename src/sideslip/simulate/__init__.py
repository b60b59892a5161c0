"""The simulator: truth model, sensor models, scenarios (never imported by the methods).

``simulate(scenario, seed=0, vehicle=None, config=None) -> Drive``; ``scenario_names()``;
``describe(name)``; ``SensorConfig`` for the sensor grades.
"""

from sideslip.simulate.run import describe, drive_from_truth, scenario_names, simulate
from sideslip.simulate.sensors import SensorConfig

__all__ = ["SensorConfig", "describe", "drive_from_truth", "scenario_names", "simulate"]
