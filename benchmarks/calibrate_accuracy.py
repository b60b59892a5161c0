"""`sideslip calibrate` against the simulator's truth: recovered values vs truth per scenario,
and mkf's beta RMSE with the right vehicle file, one 30 % off in cornering stiffness, and the
file calibrate fitted from that rough one.  Writes benchmarks/results/calibrate_accuracy.md.

Truth: :func:`sideslip.calibrate.truth.reference_calibration` (the simulator's reference columns
and its recorded sensor errors; effective axle stiffness as the slope of the true axle force
against the true axle slip).  ``cr_*`` scenarios come from CommonRoad's multi-body model.

Run: .venv/bin/python benchmarks/calibrate_accuracy.py [--seed 0] [--scenario S ...] [--out F]
"""

from __future__ import annotations

import argparse
import datetime as dt
import math
import time
from pathlib import Path
from typing import Any

from sideslip.calibrate import calibrate
from sideslip.calibrate.truth import reference_calibration
from sideslip.evaluate import metrics
from sideslip.methods.registry import all_methods, run_method, why_not
from sideslip.simulate import SensorConfig, simulate
from sideslip.simulate.scenarios import SCENARIOS as TRUTH_SCENARIOS
from sideslip.vehicle import load_vehicle

SCENARIOS = (
    "demo", "urban_course", "urban_highway", "suburban_outages", "two_turns_gyro_sf",
    "banked_track_turn", "step_steer", "slalom_low_mu", "race_lap",
    "cr_step_steer", "cr_slalom", "cr_circle", "urban_course/no_gnss", "two_turns_gyro_sf/soft_roll",
)  # fmt: skip
OUT = Path(__file__).parent / "results" / "calibrate_accuracy.md"
SHOWN = (
    ("cf", "cf", 1e-3, "kN/rad"), ("cr", "cr", 1e-3, "kN/rad"), ("steering_ratio", "ratio", 1.0, "-"),
    ("steer_offset_rad", "d0", 57.29578, "deg"), ("understeer_gradient", "K_us", 57.29578 * 9.80665, "deg/g"),
    ("slip_gain_k_s2_m", "K", 1e3, "ms^2/m"), ("roll_gradient_rad_per_m_s2", "roll", 57.29578 * 9.80665, "deg/g"),
    ("wheel_speed_scale", "s_w", 1.0, "-"), ("gyro_scale", "s_g", 1.0, "-"),
    ("gyro_bias_rad_s", "b_g", 57.29578, "deg/s"), ("imu_yaw_misalignment_rad", "yaw_m", 57.29578, "deg"),
    ("imu_roll_misalignment_rad", "roll_m", 57.29578, "deg"),
)  # fmt: skip


def drive_and_files(name: str, seed: int) -> tuple[Any, Any, Any]:
    """The drive, its right vehicle file and the rough one (cornering stiffness 30 % low).

    ``S/soft_roll``: the car of S with half its roll stiffness; the rough file keeps the
    nominal (twice too stiff) roll stiffness as well.
    """
    if name.endswith("/soft_roll"):
        base = name.split("/")[0]
        nominal = load_vehicle(TRUTH_SCENARIOS[base].vehicle)
        soft = nominal.with_changes(roll_stiffness=0.5 * nominal.roll_stiffness)
        drive = simulate(base, seed=seed, vehicle=soft)
        return drive, soft, nominal.with_changes(cf=0.7 * nominal.cf, cr=0.7 * nominal.cr)
    drive = drive_of(name, seed)
    right = load_vehicle(drive.meta["vehicle"])
    return drive, right, right.with_changes(cf=0.7 * right.cf, cr=0.7 * right.cr)


def drive_of(name: str, seed: int) -> Any:
    if name.endswith("/no_gnss"):
        base = name.split("/")[0]
        overrides = dict(TRUTH_SCENARIOS[base].sensor_overrides)
        overrides["gnss_rate_hz"] = 0.0
        overrides.pop("gnss_outages", None)
        return simulate(base, seed=seed, config=SensorConfig().with_overrides(overrides))
    return simulate(name, seed=seed)


def mkf_rmse(drive: Any, vehicle: Any) -> float:
    if why_not(all_methods()["mkf"], drive, vehicle) is not None:
        return math.nan
    return float(metrics(drive, run_method("mkf", drive, vehicle).series)["beta_rmse_deg"])


def roll_table(drive: Any, right: Any, rough: Any, fitted: Any) -> list[str]:
    """Roll RMSE of every method with a roll output, with the three vehicle files."""
    out = []
    for name, method in all_methods().items():
        if why_not(method, drive, rough) is not None:
            continue
        vals = [
            metrics(drive, run_method(method, drive, v).series).get("roll_rmse_deg")
            for v in (right, rough, fitted)
        ]
        if vals[0] is not None:
            out.append(f"| {name} | " + " | ".join(f"{v:.3f}" for v in vals) + " |")
    return out


def run(seed: int, scenarios: tuple[str, ...]) -> str:
    rows: list[str] = []
    zs: list[str] = []
    mk: list[str] = []
    inside = total = 0
    roll_rows: list[str] = []
    for name in scenarios:
        drive, right, rough = drive_and_files(name, seed)
        t0 = time.perf_counter()
        cal = calibrate(drive, rough)
        el = time.perf_counter() - t0
        truth = reference_calibration(drive)
        truth["steering_ratio"] = rough.steering_ratio * truth["steer_scale"]
        cells, zcells = [], []
        for key, _short, scale, _unit in SHOWN:
            f = cal.get(key)
            tv = truth.get(key, math.nan)
            tv_s = f"{tv * scale:.4g}" if math.isfinite(tv) else "–"
            if not f.informed:
                cells.append(f"left ({tv_s})")
                zcells.append("–")
                continue
            cells.append(f"{f.value * scale:.4g}±{f.sigma * scale:.2g} ({tv_s})")
            if math.isfinite(tv) and f.sigma > 0:
                z = (f.value - tv) / f.sigma
                zcells.append(f"{z:+.1f}")
                total += 1
                inside += abs(z) <= 2.0
            else:
                zcells.append("–")
        rows.append(f"| {name} | " + " | ".join(cells) + " |")
        zs.append(f"| {name} | " + " | ".join(zcells) + f" | {el:.2f} |")
        fitted = cal.vehicle
        a, b, c = mkf_rmse(drive, right), mkf_rmse(drive, rough), mkf_rmse(drive, fitted)
        cf_err = (cal.get("cf").value / truth["cf"] - 1) * 100 if "cf" in truth else math.nan
        cr_err = (cal.get("cr").value / truth["cr"] - 1) * 100 if "cr" in truth else math.nan
        sr_err = (cal.get("steering_ratio").value / truth["steering_ratio"] - 1) * 100
        mk.append(
            f"| {name} | {cf_err:+.1f} | {cr_err:+.1f} | {sr_err:+.2f} | {a:.3f} | {b:.3f} | {c:.3f} | "
            f"{(c / a - 1) * 100 if a > 0 else math.nan:+.0f} % | {len(drive) / 100 / 60:.1f} | {el:.2f} |"
        )
        if name.endswith("/soft_roll"):
            roll_rows = roll_table(drive, right, rough, fitted)
        print(f"{name}: done", flush=True)
    head = " | ".join(f"{s} ({u})" for _k, s, _sc, u in SHOWN)
    lines = [
        "# `sideslip calibrate` against simulator truth",
        "",
        f"Measured {dt.datetime.now(dt.UTC):%Y-%m-%d %H:%M} UTC by `benchmarks/calibrate_accuracy.py`, seed {seed}. "
        "Every drive is calibrated starting from its vehicle file with the cornering stiffness 30 % low "
        "(the other keys right). `cr_*`: CommonRoad's multi-body model (independent dynamics). "
        "`urban_course/no_gnss`: the same drive without the GNSS receiver. "
        "`two_turns_gyro_sf/soft_roll`: the SUV with half its roll stiffness on a flat track, the "
        "file keeping the nominal roll stiffness.",
        "",
        "Truth (`sideslip.calibrate.truth`): effective axle stiffness = slope of the true axle force "
        "against the true axle slip on rows faster than 5 m/s below 0.4 g; understeer gradient = slope of "
        "delta - atan(L r / v) against f_y; steering ratio truth = file ratio x true steer scale; sensor "
        "errors as drawn by the simulator.",
        "",
        "## Before / after: mkf beta RMSE (deg) and the fitted values' errors",
        "",
        "| scenario | cf err % | cr err % | ratio err % | mkf right file | mkf 30 % off | mkf fitted | fitted vs right | drive min | calibrate s |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|",
        *mk,
        "",
        "## Fitted value ± 1σ (truth)",
        "",
        "`left`: the drive could not inform it; the file's value is kept (truth in brackets).",
        "",
        f"| scenario | {head} |",
        "|---|" + "---:|" * len(SHOWN),
        *rows,
        "",
        "## (fitted - truth) / σ",
        "",
        f"| scenario | {' | '.join(s for _k, s, _sc, _u in SHOWN)} | calibrate s |",
        "|---|" + "---:|" * (len(SHOWN) + 1),
        *zs,
        "",
        f"Share of identified values within 2σ of the truth: {inside}/{total} = "
        f"{inside / max(total, 1):.2f} (a calibrated Gaussian gives 0.95).",
        "",
        "## Roll RMSE (deg) of the methods with roll on the soft car (`two_turns_gyro_sf/soft_roll`)",
        "",
        "| method | right file | rough file (roll stiffness 2x, cf/cr -30 %) | fitted file |",
        "|---|---:|---:|---:|",
        *roll_rows,
        "",
        "## Reading the table",
        "",
        "- `left` is the calibration saying the drive cannot tell a value: short manoeuvres at one "
        "speed (step_steer, cr_*) cannot separate the steer scale from the understeer gradient; a "
        "drive at one operating point cannot give both axles; the roll gradient is left wherever "
        "the road's bank varies or follows the turns (urban crossfall, superelevation, banked track) "
        "or GNSS is slower than 2 Hz; the IMU roll misalignment is always confounded with the "
        "road's crossfall. A `left` stiffness keeps the rough file's value, so mkf with the fitted "
        "file stays at its 30 %-off figure there (step_steer).",
        "- Where calibrate fits, mkf with the fitted file is within a few per cent of the right file "
        "or better (the effective stiffness suits a linear model better than the nominal one).",
        "- Known misses: urban_highway's rear axle (+22 %, 3σ; its small slip angles against the "
        "gyro-scale error of the heading), race_lap's steering ratio (+7 %, 3σ; no low-speed rows "
        "and tyres near their limit), the steer offset on slalom_low_mu (3σ of 0.004 deg).",
        "- Roll on the soft car: the fitted roll gradient (11.05 ± 0.45 deg/g, truth 11.13, file 5.1) "
        "brings obs_*/roll_index to the right file's roll RMSE; roll_dfc gets worse because it leans "
        "hard on the understeer gradient, which this single-speed track fits 25 % low (1.6σ).",
        "",
    ]
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--scenario", action="append")
    parser.add_argument("--out", type=Path)
    args = parser.parse_args()
    scen = tuple(args.scenario) if args.scenario else SCENARIOS
    text = run(args.seed, scen)
    out = args.out or (None if args.scenario else OUT)
    if out is None:
        print(text)
        return
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(text)
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
