"""Beta RMSE of methods over several simulation seeds: how much of a seed-0 difference is noise.

`compare_methods.py` ranks the methods on seed 0 only.  On the short transients (step_steer:
2 s of straight before the step) the level of the estimated slip in a turn is pinned, for a
method that learns the stiffness with GNSS, only by the heading the 2 s straight gives
(Doppler course and gyro bias), so its seed-0 error is one draw of a spread as wide as the
difference being ranked.  This prints, per scenario and vehicle file (right, cornering
stiffness 30 % low), each seed's RMSE and mean error (deg, rows faster than 5 m/s), and their
mean and spread over the seeds.

Run: .venv/bin/python benchmarks/seed_spread.py [--seeds 6] [--method M ...] [--scenario S ...]
"""

from __future__ import annotations

import argparse

import numpy as np

from sideslip.evaluate import SPEED_GATE
from sideslip.frames import wrap_angle
from sideslip.methods.registry import all_methods, run_method, why_not
from sideslip.simulate import simulate
from sideslip.vehicle import load_vehicle

DEFAULT_SCENARIOS = ("step_steer", "two_turns_gyro_sf", "cr_step_steer")
DEFAULT_METHODS = ("fused", "fg_batch")


def spread(scenarios: list[str], methods: list[str], seeds: int) -> str:
    lines = ["| scenario | file | method | per-seed RMSE | mean RMSE | std | per-seed mean error |",
             "|---|---|---|---|---:|---:|---|"]  # fmt: skip
    registry = all_methods()
    for scenario in scenarios:
        drives = [simulate(scenario, seed=s) for s in range(seeds)]
        for factor in (1.0, 0.7):
            for name in methods:
                rmse, bias = [], []
                for drive in drives:
                    base = load_vehicle(drive.meta["vehicle"])
                    vehicle = base.with_changes(cf=factor * base.cf, cr=factor * base.cr)
                    if why_not(registry[name], drive, vehicle) is not None:
                        break
                    est = run_method(registry[name], drive, vehicle)
                    gate = drive["ref_vx"] > SPEED_GATE
                    err = np.degrees(wrap_angle(est["beta"] - drive["ref_beta"]))[gate]
                    rmse.append(float(np.sqrt(np.mean(err**2))))
                    bias.append(float(np.mean(err)))
                if len(rmse) < seeds:
                    continue
                file = "right" if factor == 1.0 else "30 % low"
                lines.append(
                    f"| {scenario} | {file} | {name} | {' '.join(f'{r:.3f}' for r in rmse)} | "
                    f"{np.mean(rmse):.4f} | {np.std(rmse):.4f} | {' '.join(f'{b:+.3f}' for b in bias)} |"
                )
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--seeds", type=int, default=6)
    parser.add_argument("--method", action="append", help="method (repeatable)")
    parser.add_argument("--scenario", action="append", help="scenario (repeatable)")
    args = parser.parse_args()
    print(spread(args.scenario or list(DEFAULT_SCENARIOS), args.method or list(DEFAULT_METHODS), args.seeds))


if __name__ == "__main__":
    main()
