"""Faults of a real logger, measured: holes in the IMU, pauses of the logger, a late GNSS
Doppler, a late IMU.

Every scenario (seed 0) with its own receiver and without GNSS, clean and with one fault at a
time: eight 0.5 s holes in the yaw gyro; eight 0.5 s holes in each of a_x, a_y and w_z (at
other places); three 2 s pauses of the logger (rows missing, the time stamps jump); every
GNSS epoch 200 ms late (``gnss_latency_s``, as from a logger that stamps messages on
arrival); the IMU's samples 50 ms late against the rest of the table; no ``ax`` column at
all (a yaw-rate / lateral sensor cluster: ``fused`` reads the speed's rate for it).  Right
vehicle file;
beta RMSE in degrees on rows faster than 5 m/s, the share of beta errors inside 2 beta_std
in brackets.  The inputs' gaps are handled by ``sideslip.methods.input_gaps``, the late
Doppler by ``sideslip.doppler_timing``, the late IMU by ``sideslip.imu_timing`` (where the
Doppler's turns decide its lag).  Writes ``benchmarks/results/input_faults.md``.
Run: ``.venv/bin/python benchmarks/input_faults.py [--scenario S ...]``.
"""

from __future__ import annotations

import datetime as dt
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

import numpy as np
from compare_methods import two_sigma_share
from results_file import scenario_main

from sideslip.drive import Drive, drive_from_columns
from sideslip.evaluate import metrics
from sideslip.methods.registry import all_methods, run_method, why_not
from sideslip.simulate import SensorConfig, simulate
from sideslip.simulate.run import _lookup  # the scenario's own sensor overrides
from sideslip.vehicle import load_vehicle

OUT = Path(__file__).parent / "results" / "input_faults.md"
SCENARIOS = ("race_lap", "cr_limit_ramp", "cr_limit_slalom", "urban_course")
METHODS = ("fused", "fused_filter", "doppler_slip", "kkf", "fg_batch")
IMU = ("ax", "ay", "az", "wx", "wy", "wz")


def _holes(drive: Drive, names: tuple[str, ...], seed: int = 1) -> Drive:
    """Eight 0.5 s holes (NaN) in each column of ``names``, at random places."""
    rng = np.random.default_rng(seed)
    width = round(0.5 / drive.dt_median)
    data = dict(drive.data)
    for name in names:
        col = np.array(data[name], dtype=float)
        for start in rng.integers(0, col.size - width, 8):
            col[start : start + width] = np.nan
        data[name] = col
    return replace(drive, data=data)


def _pauses(drive: Drive) -> Drive:
    """The rows of three 2 s spans missing (at a quarter, half and three quarters)."""
    t = drive.t
    keep = np.ones(t.size, dtype=bool)
    for f in (0.25, 0.5, 0.75):
        a = t[0] + f * (t[-1] - t[0])
        keep &= ~((t > a) & (t < a + 2.0))
    return drive_from_columns({"t": t[keep], **{k: np.asarray(v)[keep] for k, v in drive.data.items()}})


def _imu_late(drive: Drive, late_s: float = 0.05) -> Drive:
    """The IMU's samples ``late_s`` later than they were taken (the first rows empty)."""
    k = round(late_s / drive.dt_median)
    data = dict(drive.data)
    for name in IMU:
        if name in data:
            col = np.full(len(drive), np.nan)
            col[k:] = np.asarray(data[name], dtype=float)[:-k]
            data[name] = col
    return replace(drive, data=data)


FAULTS: dict[str, Callable[[Drive], Drive]] = {
    "none": lambda d: d,
    "gyro holes": lambda d: _holes(d, ("wz",)),
    "IMU holes": lambda d: _holes(d, ("ax", "ay", "wz")),
    "logger pauses": _pauses,
    "IMU 50 ms late": _imu_late,
    "no ax column": lambda d: replace(d, data={k: v for k, v in d.data.items() if k != "ax"}),
}


def _drive(name: str, receiver: str, doppler_late: bool) -> Drive:
    cfg = SensorConfig().with_overrides(_lookup(name).sensor_overrides)
    if doppler_late:
        cfg = cfg.with_overrides({"gnss_latency_s": 0.2})
    drive = simulate(name, seed=0, config=cfg)
    if receiver == "none":
        drive = replace(drive, data={k: v for k, v in drive.data.items() if not k.startswith("gnss")})
    return drive


def run(scenarios: tuple[str, ...]) -> str:
    when = f"{dt.datetime.now(dt.UTC):%Y-%m-%d %H:%M}"
    about = " ".join(__doc__.split("\n\n")[1].split())
    lines = ["# Faults of a real logger", "", f"Measured {when} UTC by `benchmarks/input_faults.py`.  {about}", ""]
    lines.append("| scenario | GNSS | fault | " + " | ".join(METHODS) + " |")
    lines.append("|---|---|---|" + "---:|" * len(METHODS))
    registry = all_methods()
    cases = [(r, f) for r in ("doppler", "none") for f in FAULTS]
    cases.insert(len(FAULTS), ("doppler", "Doppler 200 ms late"))
    for name in scenarios:
        vehicle = None
        for receiver, fault in cases:
            whole = _drive(name, receiver, fault == "Doppler 200 ms late")
            vehicle = vehicle or load_vehicle(whole.meta["vehicle"])
            drive = FAULTS.get(fault, FAULTS["none"])(whole)
            cells = []
            for method in METHODS:
                if why_not(registry[method], drive, vehicle):
                    cells.append("–")
                    continue
                est = run_method(method, drive, vehicle)
                rmse = metrics(drive, est.series)["beta_rmse_deg"]
                share = two_sigma_share(drive, est)
                cells.append(f"{rmse:.3f}" + (f" ({share:.2f})" if share is not None else ""))
            lines.append(f"| {name} | {receiver} | {fault} | " + " | ".join(cells) + " |")
            print(lines[-1], flush=True)
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    scenario_main(__doc__, run, SCENARIOS, OUT)
