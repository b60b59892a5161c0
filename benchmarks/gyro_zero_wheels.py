"""The gyro zero from the rear wheels' speed difference (``sideslip.calibrate.wheel_yaw``), the
fallback of ``sideslip.calibrate.sensors.drive_gyro_bias`` where neither GNSS course nor
standstill tells the zero: before, a drive without GNSS and without 5 s of standstill left an
uncalibrated gyro's degrees per second in every method whose paper assumes a zeroed gyro.

Run: .venv/bin/python benchmarks/gyro_zero_wheels.py
Writes benchmarks/results/gyro_zero_wheels.md.

(a) real data: the comma2k19 minute (phone gyro, -3.9 deg/s raw, rear ABS wheel speeds) and
    its 30 s halves with the GNSS columns removed, where ../shared/data is present: the zero
    before (none) -> after, and beta RMSE (deg, against comma's pose) of every method that
    subtracts the zero or starts a bias state from it.
(b) simulated: every comparison scenario x seeds 0-1 without GNSS, with the simulator's
    turn-on bias (0.2 deg/s rms) and with an uncalibrated gyro's (3 deg/s rms): the wheels'
    zero against the truth (the simulator's mean yaw-gyro bias), which zero the drive uses,
    and the methods' beta RMSE before -> after where the wheels' zero is the one used.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
from compare_methods import SCENARIOS
from gyro_zero_short import METHODS, clip_of, clip_table_head, zero_rules
from results_file import write_result

import sideslip.calibrate.sensors as sensors
from sideslip.calibrate.result import Fitted
from sideslip.calibrate.wheel_yaw import wheel_gyro_zero
from sideslip.drive import Drive
from sideslip.evaluate import metrics
from sideslip.methods.registry import get_method, run_method, why_not
from sideslip.simulate import SensorConfig, simulate
from sideslip.simulate.run import _lookup
from sideslip.vehicle import Vehicle, load_vehicle

OUT = Path(__file__).parent / "results" / "gyro_zero_wheels.md"
RAW_DEG_S = 3.0  # rms turn-on bias of an uncalibrated MEMS gyro
COMMA = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "comma2k19_example1"
COMMA_SEGMENT = COMMA / "b0c9d2329ad1606b_2018-08-02--08-34-47_40"
CLIPS = ((0.0, 1e9), (0.0, 30.0), (30.0, 60.0))  # s from the segment's start


def _before_after(work: Callable[[], Any]) -> tuple[Any, Any]:
    """``work()`` with the rear-wheel fallback off, then on."""
    with zero_rules(wheels=False):
        before = work()
    return before, work()


def _no_gnss(drive: Drive) -> Drive:
    return replace(drive, data={k: v for k, v in drive.data.items() if not k.startswith("gnss")})


def _zero_cell(fit: Fitted) -> str:
    return f"{math.degrees(fit.value):+.2f} ± {math.degrees(fit.sigma):.2f}" if fit.informed else "–"


def _rmse(drive: Drive, vehicle: Vehicle) -> dict[str, float]:
    """beta RMSE (deg) of every method of ``METHODS`` the drive's columns allow (NaN: not run)."""
    out = {}
    for m in METHODS:
        if why_not(get_method(m), drive, vehicle):
            out[m] = math.nan
        else:
            out[m] = metrics(drive, run_method(m, drive, vehicle).series)["beta_rmse_deg"]
    return out


def _pair(before: float, after: float) -> str:
    return "–" if math.isnan(before) else f"{before:.3f} -> {after:.3f}"


def comma_table() -> list[str]:
    if not COMMA_SEGMENT.is_dir():
        return ["## (a) comma2k19: ../shared/data not present, not run", ""]
    from sideslip.io import convert

    drive = convert("comma2k19", COMMA_SEGMENT, None, None)
    vehicle = load_vehicle("rav4")
    pose_bias = float(np.nanmean(drive["wz"] - drive["ref_r"]))
    lines = clip_table_head(
        "## (a) The comma2k19 minute without its GNSS columns, before -> after",
        f"The whole minute's zero from its GNSS course: "
        f"{math.degrees(sensors.drive_gyro_bias(drive, vehicle).value):+.3f} deg/s; the mean of "
        f"w_z - r against comma's pose: {math.degrees(pose_bias):+.3f} deg/s.",
    )
    for t0, t1 in CLIPS:
        clip = _no_gnss(clip_of(drive, t0, t1))
        zeros = _before_after(lambda c=clip: sensors.drive_gyro_bias(c, vehicle))
        rmse = _before_after(lambda c=clip: _rmse(c, vehicle))
        span = "whole" if t1 > 1e8 else f"{t0:g}-{t1:g}"
        row = [span, " -> ".join(_zero_cell(z) for z in zeros)]
        row += [_pair(rmse[0][m], rmse[1][m]) for m in METHODS]
        lines.append("| " + " | ".join(row) + " |")
    return [*lines, ""]


def _sim(name: str, seed: int, raw: bool) -> Drive:
    over: dict[str, Any] = {"gyro_bias_std": math.radians(RAW_DEG_S)} if raw else {}
    config = SensorConfig().with_overrides(_lookup(name).sensor_overrides).with_overrides(over)
    return _no_gnss(simulate(name, seed=seed, config=config))


def sim_tables() -> list[str]:
    fits = [
        "## (b) Simulated drives without GNSS",
        "",
        "The wheels' zero (± its 1-sigma; – where the drive does not tell it: under 20 s of "
        "steady driving on the wheels, or one speed all drive long) against the truth, and "
        "where the drive's zero comes from (standstill, or the wheels where there is none).",
        "",
        "| gyro | scenario | seed | truth | wheels | used | from |",
        "|---|---|---:|---:|---:|---:|---|",
    ]
    effect: dict[str, list[tuple[float, float]]] = {m: [] for m in METHODS}
    moved: list[str] = []
    errors: list[float] = []
    for raw in (False, True):
        for name in SCENARIOS:
            for seed in (0, 1):
                drive = _sim(name, seed, raw)
                vehicle = load_vehicle(drive.meta["vehicle"])
                truth = float(drive.meta["truth_sensor"]["gyro_bias_mean"][2])
                wheels = wheel_gyro_zero(drive, vehicle.track_rear)
                used = sensors.drive_gyro_bias(drive, vehicle)
                origin = "wheels" if "wheel" in used.source else ("standstill" if used.informed else "–")
                gyro = f"{RAW_DEG_S:g} deg/s" if raw else "0.2 deg/s"
                fits.append(
                    f"| {gyro} | {name} | {seed} | {math.degrees(truth):+.2f} | {_zero_cell(wheels)} "
                    f"| {_zero_cell(used)} | {origin} |"
                )
                if wheels.informed:
                    errors.append((wheels.value - truth) / wheels.sigma)
                if origin != "wheels":
                    continue
                before, after = _before_after(lambda d=drive, v=vehicle: _rmse(d, v))
                for m in METHODS:
                    if math.isnan(before[m]):
                        continue
                    effect[m].append((before[m], after[m]))
                    if abs(after[m] - before[m]) > 0.05:
                        moved.append(f"{m} {name} seed {seed} ({gyro}): {before[m]:.3f} -> {after[m]:.3f}")
    z = np.abs(np.array(errors))
    fits += [
        "",
        f"Wheels' zero told on {z.size} drives; |error| / 1-sigma: median {np.median(z):.2f}, "
        f"largest {z.max():.2f}; share within 2 sigma {np.mean(z <= 2.0):.2f}."
        if z.size
        else "The wheels told no zero.",
        "",
        "Methods on the drives whose zero came from the wheels: mean beta RMSE (deg) before -> after.",
        "",
        "| method | drives | beta RMSE |",
        "|---|---:|---:|",
    ]
    for m in METHODS:
        pairs = effect[m]
        if pairs:
            b, a = np.mean([p[0] for p in pairs]), np.mean([p[1] for p in pairs])
            fits.append(f"| {m} | {len(pairs)} | {b:.3f} -> {a:.3f} |")
    fits += ["", "Moved by more than 0.05 deg: " + ("; ".join(moved) if moved else "none") + ".", ""]
    return fits


def main() -> None:
    start = time.perf_counter()
    body = [*comma_table(), *sim_tables()]
    write_result(
        OUT, "The gyro zero from the rear wheels", "benchmarks/gyro_zero_wheels.py", time.perf_counter() - start,
        "Where a drive has neither GNSS course nor 5 s of standstill, its gyro zero now comes from the "
        "rear wheels' speed difference (sideslip.calibrate.wheel_yaw: window means of w_z against "
        "v_rr - v_rl and the speed, which separates the bias from the wheels' radius mismatch where the "
        "speed changes).  Before: the zero stayed untold and the samples were used as recorded.",
        body,
    )  # fmt: skip


if __name__ == "__main__":
    main()
