"""The drive's own steering zero (``sideslip.calibrate.steer_zero``): how well it recovers the
simulator's drawn sensor offset, and what subtracting it does to every method that reads the
steer (``zero_steer`` on, the default, against off: the steer as recorded).

Run: .venv/bin/python benchmarks/steer_zero.py [--seeds 3]
Writes benchmarks/results/steer_zero.md.

(a) offset against truth: every scenario of compare_methods.py, seeds 0..n-1 (the simulator
    draws the offset at 0.1 deg road wheel rms; CommonRoad's multi-body drives take the same
    sensor model), with the fit's 1-sigma and the cost per drive.
(b) beta RMSE (deg, rows above 5 m/s) of the steer-reading paper methods with the zero on and
    off, seed 0, right file and one 30 % soft in cornering stiffness; roll RMSE (deg) of the
    roll estimators; and the real drives in ../shared/data (Revs lap; comma2k19 minute against
    comma's pose), where present.
(c) cost: each of these methods with the zero off and on, on urban_highway.
"""

from __future__ import annotations

import argparse
import math
import time
from pathlib import Path

import numpy as np
from compare_methods import FILES, REVS_LAP, SCENARIOS, load_scenario
from results_file import write_result

from sideslip.calibrate.steer_zero import drive_steer_offset, subtracted_offset
from sideslip.evaluate import metrics
from sideslip.methods.registry import all_methods, run_method, why_not

OUT = Path(__file__).parent / "results" / "steer_zero.md"
BETA_METHODS = (
    "fg_batch", "fg_lag", "kf_linear", "mkf", "mkf_adaptive", "obs_bicycle", "obs_kinematic",
    "obs_modified", "obs_modified_nocomp",
)  # fmt: skip
ROLL_METHODS = ("roll_index", "roll_dfc")
COMMA = REVS_LAP.parent / "comma2k19_example1" / "b0c9d2329ad1606b_2018-08-02--08-34-47_40"


def offset_table(seeds: int) -> list[str]:
    lines = [
        "## (a) The offset against the simulator's drawn offset",
        "",
        "| scenario | seed | truth (deg) | fitted (deg) | 1σ (deg) | error / σ | subtracted | cost (s) |",
        "|---|---:|---:|---:|---:|---:|---|---:|",
    ]
    err, z, cost = [], [], []
    left = []
    for name in SCENARIOS:
        for seed in range(seeds):
            drive, vehicle = load_scenario(name, seed)
            start = time.perf_counter()
            fit = drive_steer_offset(drive, vehicle)  # type: ignore[arg-type]
            cost.append(time.perf_counter() - start)
            truth = float(drive.meta["truth_sensor"]["steer_offset"])  # type: ignore[attr-defined]
            if not fit.informed:
                left.append(f"{name} seed {seed} ({fit.note})")
                lines.append(
                    f"| {name} | {seed} | {math.degrees(truth):+.3f} | – | – | – | no | {cost[-1]:.3f} |"
                )
                continue
            e = fit.value - truth
            err.append(e)
            z.append(e / fit.sigma)
            sub = "yes" if subtracted_offset(fit) != 0.0 else "no"
            lines.append(
                f"| {name} | {seed} | {math.degrees(truth):+.3f} | {math.degrees(fit.value):+.3f} | "
                f"{math.degrees(fit.sigma):.3f} | {z[-1]:+.2f} | {sub} | {cost[-1]:.3f} |"
            )
    za = np.abs(np.array(z))
    lines += [
        "",
        f"Informed on {len(err)} of {len(err) + len(left)} drives; error {math.degrees(float(np.sqrt(np.mean(np.square(err))))):.3f} deg rms, "
        f"error/σ rms {float(np.sqrt(np.mean(za**2))):.2f}, {100 * float(np.mean(za < 2)):.0f} % inside 2σ, "
        f"worst {float(za.max()):.2f}σ; cost {1000 * float(np.median(cost)):.0f} ms median, {1000 * max(cost):.0f} ms max.",
    ]
    if left:
        lines.append("Not informed: " + "; ".join(left) + ".")
    return [*lines, ""]


def _rmse(drive: object, est: object, key: str) -> float | None:
    if key == "roll":
        if "roll" not in est.series or "ref_roll" not in drive:  # type: ignore[attr-defined,operator]
            return None
        gate = np.abs(drive["ref_vx"]) > 5.0  # type: ignore[index]
        d = (est["roll"] - drive["ref_roll"])[gate]  # type: ignore[index]
        return math.degrees(float(np.sqrt(np.mean(d**2))))
    return metrics(drive, est.series).get("beta_rmse_deg")  # type: ignore[arg-type,attr-defined]


def effect_tables() -> list[str]:
    out: list[str] = []
    real = {}
    if REVS_LAP.is_dir():
        real["revs_lap"] = load_scenario("revs_lap", 0)
    if COMMA.is_dir():
        from sideslip.io.comma2k19 import convert_comma2k19
        from sideslip.vehicle import load_vehicle

        vehicle = load_vehicle("rav4")
        real["comma_minute"] = (convert_comma2k19(COMMA, vehicle), vehicle)
    for file_key, (title, make_file) in FILES.items():
        if file_key == "rough":
            continue
        for key, methods in (("beta", BETA_METHODS), ("roll", ROLL_METHODS)):
            names = SCENARIOS + (tuple(real) if file_key == "right" else ())
            cells: dict[str, dict[str, str]] = {m: {} for m in methods}
            sums: dict[str, list[float]] = {m: [0.0, 0.0, 0.0] for m in methods}
            for name in names:
                drive, base = real[name] if name in real else load_scenario(name, 0)
                vehicle = make_file(base)
                for m in methods:
                    if why_not(all_methods()[m], drive, vehicle) is not None:  # type: ignore[arg-type]
                        continue
                    on = _rmse(drive, run_method(m, drive, vehicle), key)  # type: ignore[arg-type]
                    off = _rmse(drive, run_method(m, drive, vehicle, {"zero_steer": False}), key)  # type: ignore[arg-type]
                    if on is None or off is None:
                        continue
                    cells[m][name] = f"{off:.3f} → {on:.3f}"
                    if name in SCENARIOS:
                        sums[m][0] += off
                        sums[m][1] += on
                        sums[m][2] += 1
            what = "beta" if key == "beta" else "roll"
            out += [f"### {what} RMSE (deg), {title}: steer as recorded → through the drive's zero", ""]
            out.append(
                "| method | " + " | ".join(names) + " | mean (simulated) | better / worse by > 0.005 |"
            )
            out.append("|---|" + "---:|" * (len(names) + 2))
            for m in methods:
                if not cells[m]:
                    continue
                pairs = [
                    tuple(float(x) for x in c.split(" → ")) for k, c in cells[m].items() if k in SCENARIOS
                ]
                better = sum(b < a - 0.005 for a, b in pairs)
                worse = sum(b > a + 0.005 for a, b in pairs)
                n = max(sums[m][2], 1.0)
                row = [cells[m].get(name, "–") for name in names]
                out.append(
                    f"| {m} | "
                    + " | ".join(row)
                    + f" | {sums[m][0] / n:.3f} → {sums[m][1] / n:.3f} | {better} / {worse} |"
                )
            out.append("")
    return out


def speed_table() -> list[str]:
    """Seconds per run (best of 3 after a warm-up) with the zero off and on, urban_highway."""
    drive, vehicle = load_scenario("urban_highway", 0)
    n = len(drive)  # type: ignore[arg-type]
    lines = [
        "## (c) Cost",
        "",
        f"urban_highway seed 0 ({n:,} rows, 670 s at 100 Hz); best of 3 runs after a warm-up, one process.",
        "",
        "| method | zero off (s) | zero on (s) | samples/s off | samples/s on |",
        "|---|---:|---:|---:|---:|",
    ]
    for m in (*BETA_METHODS, *ROLL_METHODS):
        best = {}
        for on in (False, True):
            run_method(m, drive, vehicle, {"zero_steer": on})  # type: ignore[arg-type]
            times = []
            for _ in range(3):
                start = time.perf_counter()
                run_method(m, drive, vehicle, {"zero_steer": on})  # type: ignore[arg-type]
                times.append(time.perf_counter() - start)
            best[on] = min(times)
        lines.append(
            f"| {m} | {best[False]:.3f} | {best[True]:.3f} | {n / best[False]:,.0f} | {n / best[True]:,.0f} |"
        )
    return [*lines, ""]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--seeds", type=int, default=3)
    args = parser.parse_args()
    start = time.perf_counter()
    body = [
        *offset_table(args.seeds),
        "## (b) Effect on the methods, seed 0",
        "",
        *effect_tables(),
        *speed_table(),
    ]
    write_result(
        OUT, "The drive's own steering zero", "benchmarks/steer_zero.py", time.perf_counter() - start,
        "`sideslip.calibrate.steer_zero.drive_steer_offset` fits calibrate's steering relation "
        "alone on the drive's 0.1 s grid; the paper methods that read the steer subtract it where "
        "it is more than 2σ from 0 (`zero_steer`, on by default).  Truth: the simulator's drawn "
        "sensor offset (`meta.truth_sensor.steer_offset`, road wheel).",
        body,
    )  # fmt: skip


if __name__ == "__main__":
    main()
