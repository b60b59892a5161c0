"""doppler_slip's heading fit: gyro scale against the simulated one, and beta, over seeds.

The heading fit's gyro scale is only as good as the sideslip model it subtracts from the
course; this prints, per simulated scenario (right vehicle file, seeds 0-2), each variant's
beta RMSE (mean over the seeds, deg, rows faster than 5 m/s), worst 2-sigma share, and the
gyro scale (measured / true) of the seed with the largest z = |scale - simulated| / sigma.
Results and the before column: benchmarks/results/doppler_slip_accuracy.md.

Run: .venv/bin/python benchmarks/doppler_gyro_scale.py [--seeds 3]
"""

from __future__ import annotations

import argparse

import numpy as np
from compare_methods import SCENARIOS, load_scenario, two_sigma_share

from sideslip.evaluate import SPEED_GATE
from sideslip.frames import wrap_angle
from sideslip.methods.registry import run_method

METHODS = ("doppler_slip", "doppler_slip_noroll")


def table(seeds: int) -> str:
    lines: list[str] = []
    rows: dict[str, list[list[dict[str, float]]]] = {m: [] for m in METHODS}
    names = [s for s in SCENARIOS if s != "revs_lap"]
    for scenario in names:
        per = {m: [] for m in METHODS}
        for seed in range(seeds):
            drive, vehicle = load_scenario(scenario, seed, "doppler")
            fast = drive["ref_vx"] > SPEED_GATE
            truth = 1.0 + drive.meta["truth_sensor"]["gyro_scale_factor"]
            for m in METHODS:
                est = run_method(m, drive, vehicle)
                err = np.degrees(wrap_angle(est["beta"] - drive["ref_beta"]))[fast]
                per[m].append({"rmse": float(np.sqrt(np.mean(err**2))),
                               "share": two_sigma_share(drive, est),
                               "scale": float(est.params["gyro_scale"]),
                               "sigma": float(est.params["gyro_scale_sigma"]), "truth": truth})  # fmt: skip
        for m in METHODS:
            rows[m].append(per[m])
    for m in METHODS:
        lines += [f"\n### {m}\n", "| scenario | beta RMSE | worst 2-sigma share | gyro scale (z) |",
                  "|---|---:|---:|---:|"]  # fmt: skip
        zs = []
        for scenario, per in zip(names, rows[m], strict=True):
            z = [abs(p["scale"] - p["truth"]) / p["sigma"] for p in per]
            w = per[int(np.argmax(z))]
            zs.append(max(z))
            lines.append(f"| {scenario} | {np.mean([p['rmse'] for p in per]):.3f} | "
                         f"{min(p['share'] for p in per):.2f} | "
                         f"{w['scale']:.3f} ± {w['sigma']:.3f} ({max(z):.1f}) |")  # fmt: skip
        mean = np.mean([np.mean([p["rmse"] for p in per]) for per in rows[m]])
        worst = min(min(p["share"] for p in per) for per in rows[m])
        lines.append(f"| mean / min / worst z | {mean:.3f} | {worst:.2f} | {max(zs):.1f} |")
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=3)
    print(table(parser.parse_args().seeds))


if __name__ == "__main__":
    main()
