"""Issue 15 point 1: ``fused`` without GNSS against the best paper method the same columns allow.

Every simulated scenario of the comparison with its GNSS columns removed (IMU, wheel speeds,
steering only, as on the Revs lap), the right vehicle file, seed 0; beta RMSE in degrees on rows
faster than 5 m/s (the contract metric).  Writes ``benchmarks/results/no_gnss.md``.
Run: ``.venv/bin/python benchmarks/no_gnss.py``.
"""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

from compare_methods import load_scenario

from sideslip.evaluate import metrics
from sideslip.methods.registry import all_methods, run_method, why_not

OUT = Path(__file__).parent / "results" / "no_gnss.md"
SCENARIOS = ("step_steer", "slalom_low_mu", "banked_turn", "dlc_bank", "race_lap", "urban_course",
             "cr_step_steer", "cr_slalom", "cr_circle", "cr_limit_slalom", "cr_limit_ramp")  # fmt: skip
OURS = ("fused", "fused_filter")


def main() -> None:
    rows = ["# fused without GNSS", "", __doc__.split("\n\n")[1].replace("\n", " "), "",
            "| scenario | fused | fused_filter | best paper method | its beta RMSE | fused / best |",
            "|---|---:|---:|---|---:|---:|"]  # fmt: skip
    for name in SCENARIOS:
        drive, vehicle = load_scenario(name, 0)
        drive = replace(drive, data={k: v for k, v in drive.data.items() if not k.startswith("gnss")})
        res: dict[str, float] = {}
        for method_name, method in all_methods().items():
            if why_not(method, drive, vehicle) is None:
                m = metrics(drive, run_method(method, drive, vehicle).series)
                if "beta_rmse_deg" in m and math.isfinite(m["beta_rmse_deg"]):
                    res[method_name] = m["beta_rmse_deg"]
        best_name = min((k for k in res if k not in OURS), key=res.__getitem__)
        best = res[best_name]
        rows.append(f"| {name} | {res['fused']:.3f} | {res['fused_filter']:.3f} | {best_name} | {best:.3f} "
                    f"| {res['fused'] / best:.2f} |")  # fmt: skip
        print(rows[-1])
    OUT.write_text("\n".join(rows) + "\n")
    print(f"wrote {OUT}")


if __name__ == "__main__":
    main()
