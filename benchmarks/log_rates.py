"""The fused estimator on tables logged at 100, 50 and 20 Hz: the inputs' quadrature.

Every simulated scenario of the comparison (seed 0, its own receiver, right vehicle file),
the whole table kept at 100 Hz or every second / fifth row kept (a logger at 50 / 20 Hz; the
10 Hz GNSS epochs all stay), with GNSS Doppler and without GNSS.  ``fused`` and
``fused_filter`` integrate the IMU over each node step by the trapezoidal rule where Doppler
is present (``FusedSettings.trapezoid_with_doppler``, the default) or by the rows' mean
(rectangle rule, half a row late; the default without Doppler); both are run with Doppler.
Per rate and receiver: the mean beta RMSE (deg, rows faster than 5 m/s) over the scenarios,
the lowest share of beta errors inside 2 beta_std, and doppler_slip's and kkf's means where
they run; then the 20 Hz Doppler cells one by one.  Writes
``benchmarks/results/log_rates.md``.  Run: ``.venv/bin/python benchmarks/log_rates.py
[--scenario S ...]``.
"""

from __future__ import annotations

import datetime as dt
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
from compare_methods import SCENARIOS, two_sigma_share
from results_file import scenario_main

from sideslip.drive import Drive
from sideslip.evaluate import metrics
from sideslip.methods.registry import run_method
from sideslip.simulate import simulate
from sideslip.vehicle import load_vehicle

OUT = Path(__file__).parent / "results" / "log_rates.md"
SIMULATED = tuple(s for s in SCENARIOS if not s.startswith("revs"))
STRIDES = {100: 1, 50: 2, 20: 5}  # table rate (Hz) -> rows kept
RECTANGLE = {"trapezoid_with_doppler": False}
PAPER = ("doppler_slip", "kkf")


def logged_at(drive: Drive, stride: int) -> Drive:
    """Every ``stride``-th row of ``drive`` (a logger that samples the bus at that rate)."""
    keep = np.zeros(len(drive), dtype=bool)
    keep[::stride] = True
    return replace(drive, t=drive.t[keep], data={k: np.asarray(v)[keep] for k, v in drive.data.items()})


def _cell(drive: Drive, vehicle, method: str, settings: dict | None = None) -> tuple[float, float]:
    est = run_method(method, drive, vehicle, settings)
    share = two_sigma_share(drive, est)
    return metrics(drive, est.series)["beta_rmse_deg"], float(share if share is not None else np.nan)


def _mean_cell(values: list[tuple[float, float]] | None) -> str:
    """Mean beta RMSE over the scenarios with the lowest 2-sigma share, or a dash."""
    if not values:
        return "–"
    vals = np.array(values)
    return f"{np.mean(vals[:, 0]):.3f} ({np.nanmin(vals[:, 1]):.2f})"


def run(scenarios: tuple[str, ...]) -> str:
    t0 = time.perf_counter()
    runs = [("fused", None), ("fused", RECTANGLE), ("fused_filter", None), ("fused_filter", RECTANGLE)]
    # (rate, receiver) -> column -> [(rmse, share) per scenario]
    table: dict[tuple[int, str], dict[str, list[tuple[float, float]]]] = {}
    per_20: list[str] = []
    for name in scenarios:
        whole = simulate(name, seed=0)
        vehicle = load_vehicle(whole.meta["vehicle"])
        for rate, stride in STRIDES.items():
            for receiver in ("doppler", "none"):
                drive = logged_at(whole, stride)
                if receiver == "none":
                    drive = replace(
                        drive, data={k: v for k, v in drive.data.items() if not k.startswith("gnss")}
                    )
                cols = table.setdefault((rate, receiver), {})
                for method, settings in runs if receiver == "doppler" else runs[::2]:
                    key = method + (" rectangle" if settings else "")
                    cols.setdefault(key, []).append(_cell(drive, vehicle, method, settings))
                for method in PAPER:
                    if receiver == "doppler":
                        cols.setdefault(method, []).append(_cell(drive, vehicle, method))
                if rate == 20 and receiver == "doppler":
                    c = {k: v[-1] for k, v in cols.items()}
                    per_20.append(
                        f"| {name} | {c['fused rectangle'][0]:.3f} | {c['fused'][0]:.3f} ({c['fused'][1]:.2f}) | "
                        f"{c['fused_filter rectangle'][0]:.3f} | {c['fused_filter'][0]:.3f} "
                        f"({c['fused_filter'][1]:.2f}) | {c['doppler_slip'][0]:.3f} | {c['kkf'][0]:.3f} |"
                    )
                print(name, rate, receiver, flush=True)
    body = [
        "Mean beta RMSE (deg) over the scenarios, lowest 2-sigma share in brackets; "
        "'rectangle': `trapezoid_with_doppler=False`.",
        "",
        "| table rate | GNSS | fused rectangle | fused | fused_filter rectangle | fused_filter | "
        "doppler_slip | kkf |",
        "|---|---|---:|---:|---:|---:|---:|---:|",
    ]
    keys = ("fused rectangle", "fused", "fused_filter rectangle", "fused_filter", *PAPER)
    for (rate, receiver), cols in table.items():
        cells = [_mean_cell(cols.get(key)) for key in keys]
        body.append(f"| {rate} Hz | {receiver} | " + " | ".join(cells) + " |")
    body += [
        "",
        "At 20 Hz with Doppler, scenario by scenario (beta RMSE, deg; 2-sigma share in brackets):",
        "",
        "| scenario | fused rectangle | fused | fused_filter rectangle | fused_filter | doppler_slip | kkf |",
        "|---|---:|---:|---:|---:|---:|---:|",
        *per_20,
        "",
    ]
    when = f"{dt.datetime.now(dt.UTC):%Y-%m-%d %H:%M}"
    about = " ".join(__doc__.split("\n\n")[1].split())
    elapsed = time.perf_counter() - t0
    head = [
        "# Tables logged at 100, 50 and 20 Hz",
        "",
        f"Measured {when} UTC by `benchmarks/log_rates.py` ({elapsed:.0f} s).  {about}",
        "",
    ]
    return "\n".join(head + body) + "\n"


if __name__ == "__main__":
    scenario_main(__doc__, run, SIMULATED, OUT)
