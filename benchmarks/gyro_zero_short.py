"""The drive's own gyro zero on drives shorter than 40 s (``sideslip.calibrate.sensors``):
before, such a drive never told the zero unless it stood still for 5 s, so the methods whose
papers assume a zeroed gyro ran on an uncalibrated gyro's degrees per second; now a drive
with 10 s of GNSS course tells it where the fit is at least 0.5 deg/s and 4 of its 1-sigma
from 0, an uncalibrated gyro (``MIN_WINDOWS_RAW``, ``RAW_BIAS_MIN``, ``RAW_BIAS_SIGMAS``).

Run: .venv/bin/python benchmarks/gyro_zero_short.py
Writes benchmarks/results/gyro_zero_short.md.

(a) the fitted zero against the simulator's mean gyro bias on every comparison scenario shorter
    than 40 s, seeds 0-1, GNSS Doppler and positions only (compare_methods' issue-15
    receiver), with the simulator's turn-on bias (0.2 deg/s rms) and with an uncalibrated
    gyro's (3 deg/s rms).
(b) beta RMSE (deg) and the share of errors inside 2 beta_std of every method that subtracts
    the zero, before -> after, on the same drives with the 3 deg/s gyro, mean over them; and
    the drives whose result moved by more than 0.05 deg.
(c) real clips: 20 and 30 s pieces of the comma2k19 minute (a phone gyro, -3.9 deg/s raw;
    the reference is comma's pose), where ../shared/data is present.
"""

from __future__ import annotations

import math
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np
from compare_methods import POSITIONS_ONLY, SCENARIOS, two_sigma_share
from results_file import write_result

import sideslip.calibrate.sensors as sensors
from sideslip.calibrate.result import Fitted, left_alone
from sideslip.evaluate import metrics
from sideslip.methods.registry import run_method
from sideslip.simulate import SensorConfig, simulate
from sideslip.simulate.run import _lookup
from sideslip.vehicle import load_vehicle

OUT = Path(__file__).parent / "results" / "gyro_zero_short.md"
SHORT_S = 40.0  # drives shorter than this never had MIN_WINDOWS of course
RAW_DEG_S = 3.0  # rms turn-on bias of an uncalibrated MEMS gyro (comma2k19's phone: -3.9 deg/s)
METHODS = (
    "fg_batch", "fg_lag", "kf_linear", "kkf", "mkf", "mkf_adaptive", "obs_bicycle",
    "obs_kinematic", "obs_modified", "obs_modified_nocomp",
)  # fmt: skip
MODES = ("doppler", "positions")


def _untold(_drive: Any, _track: float) -> Fitted:
    return left_alone("gyro_bias_rad_s", 0.0, "rad/s", "rear-wheel fallback off (before)")


@contextmanager
def zero_rules(short_drive_rule: bool = True, wheels: bool | None = None) -> Iterator[None]:
    """``drive_gyro_bias`` with or without the short-drive rule (``MIN_WINDOWS_RAW``) and the
    rear-wheel fallback (``wheels``; default: with the short-drive rule).  Before either
    (both off) a drive told the zero only with 40 s of course or 5 s of standstill."""
    saved = sensors.MIN_WINDOWS_RAW, sensors.wheel_gyro_zero
    if not short_drive_rule:
        sensors.MIN_WINDOWS_RAW = 10**9
    if not (short_drive_rule if wheels is None else wheels):
        sensors.wheel_gyro_zero = _untold  # type: ignore[assignment]
    try:
        yield
    finally:
        sensors.MIN_WINDOWS_RAW, sensors.wheel_gyro_zero = saved


def drive_for(name: str, seed: int, mode: str, raw: bool) -> Any:
    over: dict[str, Any] = dict(POSITIONS_ONLY) if mode == "positions" else {}
    if raw:
        over["gyro_bias_std"] = math.radians(RAW_DEG_S)
    config = SensorConfig().with_overrides(_lookup(name).sensor_overrides).with_overrides(over)
    return simulate(name, seed=seed, config=config)


def short_scenarios() -> list[str]:
    out = []
    for name in SCENARIOS:
        drive = simulate(name, seed=0)
        if float(drive.t[-1] - drive.t[0]) < SHORT_S:
            out.append(name)
    return out


def fit_table(names: list[str]) -> list[str]:
    lines = [
        "## (a) The fitted zero against the truth (deg/s)",
        "",
        "| gyro | GNSS | scenario | seed | truth | before | after (± 1σ) |",
        "|---|---|---|---:|---:|---:|---:|",
    ]
    errs: dict[str, list[float]] = {"before": [], "after": []}
    for raw in (False, True):
        for mode in MODES:
            for name in names:
                for seed in (0, 1):
                    drive = drive_for(name, seed, mode, raw)
                    vehicle = load_vehicle(drive.meta["vehicle"])
                    truth = float(drive.meta["truth_sensor"]["gyro_bias_mean"][2])
                    cells = []
                    for key in ("before", "after"):
                        with zero_rules(key == "after"):
                            fit = sensors.drive_gyro_bias(drive, vehicle)
                        used = sensors.subtracted_zero(fit)
                        if raw:
                            errs[key].append(math.degrees(used - truth))
                        if fit.informed:
                            cells.append(f"{math.degrees(fit.value):+.2f} ± {math.degrees(fit.sigma):.2f}")
                        else:
                            cells.append("–")
                    gyro = f"{RAW_DEG_S:g} deg/s" if raw else "0.2 deg/s"
                    lines.append(
                        f"| {gyro} | {mode} | {name} | {seed} | {math.degrees(truth):+.2f} | {cells[0]} | {cells[1]} |"
                    )
    rms = {k: float(np.sqrt(np.mean(np.square(v)))) for k, v in errs.items()}
    lines += [
        "",
        f"With the {RAW_DEG_S:g} deg/s gyro, rms of the bias left in the samples the methods use "
        f"(truth less the zero subtracted): before {rms['before']:.2f} deg/s, after {rms['after']:.2f} deg/s.",
        "",
    ]
    return lines


def effect_table(names: list[str]) -> list[str]:
    lines = [
        f"## (b) Methods on the short drives with the {RAW_DEG_S:g} deg/s gyro, before -> after",
        "",
        "Mean beta RMSE (deg) over the short drives x seeds 0-1, and the lowest share of beta "
        "errors inside 2 beta_std (– for methods without a beta_std).",
        "",
        "| method | GNSS | beta RMSE | lowest 2σ share |",
        "|---|---|---:|---:|",
    ]
    moved: list[str] = []
    for mode in MODES:
        res: dict[str, dict[str, list[tuple[float, float | None]]]] = {
            m: {"before": [], "after": []} for m in METHODS
        }
        for name in names:
            for seed in (0, 1):
                drive = drive_for(name, seed, mode, True)
                vehicle = load_vehicle(drive.meta["vehicle"])
                for method in METHODS:
                    pair = []
                    for key in ("before", "after"):
                        with zero_rules(key == "after"):
                            est = run_method(method, drive, vehicle)
                        rmse = metrics(drive, est.series)["beta_rmse_deg"]
                        res[method][key].append((rmse, two_sigma_share(drive, est)))
                        pair.append(rmse)
                    if abs(pair[1] - pair[0]) > 0.05:
                        moved.append(f"{method} {mode} {name} seed {seed}: {pair[0]:.3f} -> {pair[1]:.3f}")
        for method in METHODS:
            cells = []
            for what in ("rmse", "share"):
                vals = []
                for key in ("before", "after"):
                    got = res[method][key]
                    if what == "rmse":
                        vals.append(f"{np.mean([g[0] for g in got]):.3f}")
                    else:
                        shares = [g[1] for g in got if g[1] is not None]
                        vals.append(f"{min(shares):.2f}" if shares else "–")
                cells.append(" -> ".join(vals))
            lines.append(f"| {method} | {mode} | {cells[0]} | {cells[1]} |")
    lines += ["", "Moved by more than 0.05 deg: " + ("; ".join(moved) if moved else "none") + ".", ""]
    return lines


COMMA = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "comma2k19_example1"
COMMA_SEGMENT = COMMA / "b0c9d2329ad1606b_2018-08-02--08-34-47_40"
CLIPS = ((0.0, 20.0), (0.0, 30.0), (15.0, 45.0), (30.0, 60.0))  # s from the segment's start


def clip_table_head(title: str, intro: str) -> list[str]:
    """Title, ``intro`` and the header of a table of the comma2k19 clips: the zero, then each
    method's beta RMSE against comma's pose."""
    return [
        title,
        "",
        f"{intro}  beta RMSE (deg) against comma's pose, rows above 5 m/s.",
        "",
        "| clip (s) | zero (deg/s) | " + " | ".join(METHODS) + " |",
        "|---|---:|" + "---:|" * len(METHODS),
    ]


def clip_of(drive: Any, t0: float, t1: float) -> Any:
    """The rows of ``drive`` from ``t0`` to ``t1`` s after its start."""
    start, stop = np.searchsorted(drive.t, drive.t[0] + np.array([t0, t1]))
    return drive.slice(int(start), int(stop))


def comma_table() -> list[str]:
    if not COMMA_SEGMENT.is_dir():
        return []
    from sideslip.io import convert

    drive = convert("comma2k19", COMMA_SEGMENT, None, None)
    vehicle = load_vehicle("rav4")
    lines = clip_table_head(
        "## (c) Clips of the comma2k19 minute (phone gyro), before -> after",
        "The whole minute's zero: "
        f"{math.degrees(sensors.drive_gyro_bias(drive, vehicle).value):+.2f} deg/s.",
    )
    for t0, t1 in CLIPS:
        clip = clip_of(drive, t0, t1)
        zeros, cells = [], {m: [] for m in METHODS}
        for after in (False, True):
            with zero_rules(after):
                zero = sensors.drive_gyro_bias(clip, vehicle)
                zeros.append(f"{math.degrees(zero.value):+.2f}" if zero.informed else "–")
                for method in METHODS:
                    est = run_method(method, clip, vehicle)
                    cells[method].append(f"{metrics(clip, est.series)['beta_rmse_deg']:.3f}")
        row = [f"{t0:g}-{t1:g}", " -> ".join(zeros), *(" -> ".join(cells[m]) for m in METHODS)]
        lines.append("| " + " | ".join(row) + " |")
    return [*lines, ""]


def main() -> None:
    start = time.perf_counter()
    names = short_scenarios()
    body = [*fit_table(names), *effect_table(names), *comma_table()]
    write_result(
        OUT, "The gyro zero on short drives", "benchmarks/gyro_zero_short.py", time.perf_counter() - start,
        f"Scenarios shorter than {SHORT_S:g} s: {', '.join(names)}.  Before: such a drive tells the "
        "zero only with 5 s of standstill (nor from its rear wheels, gyro_zero_wheels.md); after: "
        "also with 10 s of GNSS course where the fit is at least 0.5 deg/s and 4σ from 0.  Truth: the simulator's mean yaw-gyro bias over the drive.",
        body,
    )  # fmt: skip


if __name__ == "__main__":
    main()
