"""Roll angle: every method with a roll output on every simulated scenario.

Roll RMSE in degrees against ``ref_roll`` (body roll to the horizontal: the suspension's roll
plus the road's bank, seed 003) on every row, seed 0, the scenarios' own receiver (GNSS with
Doppler) and the right vehicle file.  ``cr_*`` scenarios come from CommonRoad's multi-body
model (an independent truth: its suspension is not the file's roll model).  The methods: the
paper ones that estimate roll (``doppler_slip``, seed 000 eqs 15-19; ``roll_index``,
``roll_dfc`` and the observers that use them, seed 003) and ours.  An accelerometer offset
(bias, mounting) reads as a bank on a level road for every method (g times 0.05 m/s^2 is
0.3 deg), so a few tenths of a degree is the floor here.  Writes
``benchmarks/results/roll_accuracy.md``.
Run: ``.venv/bin/python benchmarks/roll_accuracy.py [--scenario S ...]``.
"""

from __future__ import annotations

import math
import time
from pathlib import Path

import numpy as np
from compare_methods import SCENARIOS, load_scenario
from results_file import scenario_main

from sideslip.evaluate import metrics
from sideslip.methods.registry import all_methods, run_method, why_not

OUT = Path(__file__).parent / "results" / "roll_accuracy.md"
# the roll index's own variants repeat its roll (obs_kinematic, obs_modified); one row of it
REPEATS = ("obs_kinematic", "obs_modified")


def _roll_rmse(name: str) -> dict[str, float]:
    """method -> roll RMSE (deg) on seed 0 of a scenario with the right vehicle file."""
    drive, vehicle = load_scenario(name, 0)
    out: dict[str, float] = {}
    if "ref_roll" not in drive:
        return out
    for method_name, method in all_methods().items():
        if method_name in REPEATS or why_not(method, drive, vehicle) is not None:
            continue
        m = metrics(drive, run_method(method, drive, vehicle).series)
        if "roll_rmse_deg" in m and math.isfinite(m["roll_rmse_deg"]):
            out[method_name] = m["roll_rmse_deg"]
    return out


def run(scenarios: tuple[str, ...]) -> str:
    start = time.perf_counter()
    res = {name: _roll_rmse(name) for name in scenarios}
    res = {k: v for k, v in res.items() if v}
    methods = sorted(set.union(*(set(v) for v in res.values())))
    head = "| method | " + " | ".join(res) + " | mean |"
    rows = [head, "|---|" + "---:|" * (len(res) + 1)]
    for m in methods:
        cells = []
        for per in res.values():
            best = min(per.values())
            v = per.get(m)
            cells.append("–" if v is None else (f"**{v:.3f}**" if v == best else f"{v:.3f}"))
        full = all(m in per for per in res.values())
        mean = f"{np.mean([per[m] for per in res.values()]):.3f}" if full else "–"
        rows.append(f"| {m} | " + " | ".join(cells) + f" | {mean} |")
    intro = " ".join(__doc__.split("\n\n")[1].split())
    stamp = time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime())
    text = [
        "# Roll angle: every method with a roll output",
        "",
        f"Measured {stamp} by `benchmarks/roll_accuracy.py`, seed 0.  {intro}",
        "",
        *rows,
        "",
        f"Run time {time.perf_counter() - start:.0f} s.",
        "",
    ]
    return "\n".join(text)


if __name__ == "__main__":
    scenario_main(__doc__, run, SCENARIOS, OUT)
