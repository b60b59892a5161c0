"""Every method side by side on every scenario: beta RMSE with the right vehicle file and with
one 30 % off in cornering stiffness; also on CommonRoad's multi-body model (dynamics nobody here
wrote).  Writes benchmarks/results/compare_methods.md.

Run: .venv/bin/python benchmarks/compare_methods.py [--seed 0]
"""

from __future__ import annotations

import argparse
import datetime as dt
import math
import time
from pathlib import Path

import numpy as np

from sideslip.evaluate import SPEED_GATE, metrics
from sideslip.frames import wrap_angle
from sideslip.methods.registry import all_methods, run_method, why_not
from sideslip.simulate import simulate
from sideslip.vehicle import load_vehicle

SCENARIOS = (
    "step_steer", "slalom_low_mu", "banked_turn", "dlc_bank", "two_turns_gyro_sf",
    "banked_track_turn", "urban_course", "urban_highway", "race_lap", "suburban_outages", "demo",
    "cr_step_steer", "cr_slalom", "cr_circle",
)  # fmt: skip
OUT = Path(__file__).parent / "results" / "compare_methods.md"


def run(seed: int) -> str:
    methods = list(all_methods())
    table: dict[float, dict[str, dict[str, float]]] = {1.0: {}, 0.7: {}}
    coverage: dict[str, tuple[float, float]] = {}
    start = time.perf_counter()
    for scenario in SCENARIOS:
        drive = simulate(scenario, seed=seed)
        base = load_vehicle(drive.meta["vehicle"])
        for factor in (1.0, 0.7):
            vehicle = base.with_changes(cf=factor * base.cf, cr=factor * base.cr)
            row: dict[str, float] = {}
            for name, method in all_methods().items():
                if why_not(method, drive, vehicle) is not None:
                    continue
                est = run_method(method, drive, vehicle)
                m = metrics(drive, est.series)
                if "beta_rmse_deg" in m:
                    row[name] = m["beta_rmse_deg"]
                if name == "fused" and factor == 1.0 and "beta_std" in est.series:
                    gate = drive["ref_vx"] > SPEED_GATE
                    z = np.abs(wrap_angle(est["beta"] - drive["ref_beta"]))[gate] / est["beta_std"][gate]
                    coverage[scenario] = (float(np.mean(z < 1)), float(np.mean(z < 2)))
            table[factor][scenario] = row
        print(f"{scenario}: done ({time.perf_counter() - start:.0f} s)", flush=True)
    lines = [
        "# Every method on every scenario",
        "",
        f"Measured {dt.datetime.now(dt.UTC):%Y-%m-%d %H:%M} UTC by `benchmarks/compare_methods.py`, "
        f"seed {seed}.  Sideslip RMSE in degrees on rows faster than {SPEED_GATE:g} m/s; the best "
        "method of each scenario in bold.  `cr_*` scenarios come from CommonRoad's multi-body "
        "model (an independent truth; vehicle file derived from its parameter set).  The mean "
        "is over the scenarios every method can run.",
        "",
    ]
    for factor, title in ((1.0, "right vehicle file"), (0.7, "cornering stiffness 30 % low in the vehicle file")):
        rows = table[factor]
        lines += [f"## {title}", "", "| method | " + " | ".join(SCENARIOS) + " | mean |",
                  "|---|" + "---:|" * (len(SCENARIOS) + 1)]
        best = {sc: min(rows[sc].values()) for sc in SCENARIOS if rows[sc]}
        means = {}
        for name in methods:
            vals = [rows[sc].get(name) for sc in SCENARIOS]
            if all(v is None for v in vals):
                continue
            cells = []
            for sc, v in zip(SCENARIOS, vals, strict=True):
                if v is None:
                    cells.append("–")
                elif math.isclose(v, best[sc]):
                    cells.append(f"**{v:.3f}**")
                else:
                    cells.append(f"{v:.3f}" if v < 100 else f"{v:.0f}")
            finite = [v for v in vals if v is not None]
            mean = float(np.mean(finite)) if len(finite) == len(SCENARIOS) else math.nan
            means[name] = mean
            lines.append(f"| {name} | " + " | ".join(cells) + (f" | {mean:.3f} |" if math.isfinite(mean) else " | – |"))
        ranked = sorted((v, k) for k, v in means.items() if math.isfinite(v))
        lines += ["", "Lowest mean: " + ", ".join(f"{k} {v:.3f}" for v, k in ranked[:5]) + ".", ""]
    lines += ["## Calibration of the fused smoother's beta_std (right vehicle file)", "",
              "| scenario | share within 1σ | share within 2σ |", "|---|---:|---:|"]
    for sc, (a, b) in coverage.items():
        lines.append(f"| {sc} | {a:.1%} | {b:.1%} |")
    lines += ["", "A calibrated Gaussian gives 68.3 % and 95.4 %; above that the sigma is conservative.", ""]
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    text = run(args.seed)
    OUT.parent.mkdir(parents=True, exist_ok=True)
    OUT.write_text(text)
    print(f"wrote {OUT}")


if __name__ == "__main__":
    main()
