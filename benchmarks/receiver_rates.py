"""Issue 15 point 1: ``fused`` with GNSS positions only at every receiver rate from 1 to 20 Hz.

Every simulated scenario of the comparison, seed 0, with a receiver that gives positions only
(no Doppler) at 1, 2, 5, 10 and 20 Hz, 50 ms late, its antenna 0.5 m ahead of where the vehicle
file says (as in compare_positions_only.md, which is the 20 Hz column); one vehicle file per
run (``--file right|soft|rough``, compare_methods.FILES).  Per rate: ``fused``'s mean beta RMSE
(deg, rows faster than 5 m/s) over the scenarios, its lowest 2-sigma share, the cells where it
is more than 10 % behind the best other registered method, and every method's mean (the
methods that ran on every scenario).  Writes ``benchmarks/results/receiver_rates_<file>.md``.
Run: ``.venv/bin/python benchmarks/receiver_rates.py [--file right] [--rates 1,2,5,10,20]``.
"""

from __future__ import annotations

import argparse
import datetime as dt
import math
import time
from pathlib import Path

import numpy as np
from compare_methods import FILES, POSITIONS_ONLY, SCENARIOS, two_sigma_share

from sideslip.evaluate import metrics
from sideslip.methods.registry import all_methods, run_method, why_not
from sideslip.simulate import SensorConfig, simulate
from sideslip.simulate.run import _lookup
from sideslip.vehicle import load_vehicle

RESULTS = Path(__file__).parent / "results"
WITHIN = 1.10  # issue 15 point 4's "within 10 % of the best"
SIMULATED = tuple(s for s in SCENARIOS if not s.startswith("revs"))


def run_rate(rate_hz: float, file_key: str) -> tuple[dict[str, dict[str, float]], dict[str, float]]:
    """scenario -> method -> beta RMSE (deg), and scenario -> fused's 2-sigma share."""
    rmse: dict[str, dict[str, float]] = {}
    share: dict[str, float] = {}
    registry = all_methods()
    for name in SIMULATED:
        config = (
            SensorConfig()
            .with_overrides(_lookup(name).sensor_overrides)
            .with_overrides({**POSITIONS_ONLY, "gnss_rate_hz": rate_hz})
        )
        drive = simulate(name, seed=0, config=config)
        vehicle = FILES[file_key][1](load_vehicle(drive.meta["vehicle"]))
        res: dict[str, float] = {}
        for method_name, method in registry.items():
            if why_not(method, drive, vehicle) is not None:
                continue
            est = run_method(method, drive, vehicle)
            m = metrics(drive, est.series)
            if "beta_rmse_deg" in m and math.isfinite(m["beta_rmse_deg"]):
                res[method_name] = m["beta_rmse_deg"]
            if method_name == "fused":
                share[name] = float(two_sigma_share(drive, est) or math.nan)
        rmse[name] = res
    return rmse, share


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--file", default="right", choices=sorted(FILES))
    parser.add_argument("--rates", default="1,2,5,10,20", help="receiver rates, Hz")
    args = parser.parse_args()
    rates = [float(r) for r in args.rates.split(",")]
    start = time.perf_counter()
    stamp = dt.datetime.now(dt.UTC).strftime("%Y-%m-%d %H:%M UTC")
    intro = " ".join(__doc__.split("\n\n")[1].split())
    lines = [f"# fused with positions-only GNSS at every receiver rate ({FILES[args.file][0]})", "",
             f"Measured {stamp}.  {intro}", "",
             "| rate Hz | fused mean | lowest 2 sigma share | next best method (mean) | cells > 10 % behind |",
             "|---:|---:|---:|---|---|"]  # fmt: skip
    means_by_rate = {}
    for rate in rates:
        rmse, share = run_rate(rate, args.file)
        common = set.intersection(*(set(r) for r in rmse.values()))
        means = {m: float(np.mean([rmse[s][m] for s in rmse])) for m in common}
        means_by_rate[rate] = means
        nxt = min((m for m in means if m != "fused"), key=means.__getitem__)
        behind = []
        for s, res in rmse.items():
            best = min((m for m in res if m not in ("fused", "fused_filter")), key=res.__getitem__)
            other = min(v for m, v in res.items() if m != "fused")
            if res["fused"] > WITHIN * other:
                who = "fused_filter" if res["fused_filter"] == other else best
                behind.append(f"{s} {res['fused']:.3f} ({who} {other:.3f})")
        lines.append(f"| {rate:g} | {means['fused']:.3f} | {min(share.values()):.2f} | {nxt} ({means[nxt]:.3f}) "
                     f"| {'; '.join(behind) or 'none'} |")  # fmt: skip
        print(lines[-1], flush=True)
    methods = sorted(set.intersection(*(set(m) for m in means_by_rate.values())),
                     key=lambda m: means_by_rate[rates[-1]][m])  # fmt: skip
    lines += ["", "Mean beta RMSE (deg) over the scenarios, every method that ran on all of them:", "",
              "| method | " + " | ".join(f"{r:g} Hz" for r in rates) + " |",
              "|---|" + "---:|" * len(rates)]  # fmt: skip
    for m in methods:
        lines.append(f"| {m} | " + " | ".join(f"{means_by_rate[r][m]:.3f}" for r in rates) + " |")
    lines += ["", f"Run time {time.perf_counter() - start:.0f} s."]
    out = RESULTS / f"receiver_rates_{args.file}.md"
    out.write_text("\n".join(lines) + "\n")
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
