"""The receiver latency identified from the fixes' speed (``sideslip.gnss_latency``), and what
using it does to ``fused`` on positions-only drives, over a grid of true latencies and antenna
lever-arm errors the vehicle file does not state.

Fixes at 20 Hz, no Doppler; latency 0 / 0.05 / 0.15 s; the antenna 0.5 m behind, at, or 0.5 m
ahead of where the file says.  An antenna ahead acts like a negative latency of l_x / v, so a
late receiver with its antenna ahead partly cancels (at 10 m/s, 50 ms late and 0.5 m ahead
cancel exactly); the grid shows both signs.  Right vehicle file, seed 0; beta RMSE in degrees,
and for fused (with the identified latency) and fused_filter the share of beta errors inside
2 beta_std and the median beta_std (deg), on rows faster than 5 m/s.
Writes ``benchmarks/results/gnss_latency.md``.
Run: ``.venv/bin/python benchmarks/gnss_latency.py [--scenario S ...]``.
"""

from __future__ import annotations

import argparse
import datetime as dt
from pathlib import Path

import numpy as np

from sideslip.evaluate import SPEED_GATE, metrics
from sideslip.gnss_latency import identify_latency
from sideslip.methods.registry import run_method
from sideslip.simulate import SensorConfig, simulate
from sideslip.simulate.run import _lookup  # the scenario's own sensor overrides
from sideslip.vehicle import load_vehicle

OUT = Path(__file__).parent / "results" / "gnss_latency.md"
SCENARIOS = ("urban_course", "demo", "race_lap", "two_turns_gyro_sf")
LATENCIES = (0.0, 0.05, 0.15)
LEVERS = (-0.5, 0.0, 0.5)


def run(scenarios: tuple[str, ...]) -> str:
    lines = [
        "# GNSS latency from the fixes' speed, and fused with it",
        "",
        f"Measured {dt.datetime.now(dt.UTC):%Y-%m-%d %H:%M} UTC by `benchmarks/gnss_latency.py`.  "
        + " ".join(__doc__.split("\n\n")[1].split()),
        "",
        "| scenario | latency s | antenna ahead m | identified → used, s | fused off | fused on | fused_filter "
        "| 2σ share on / filter | median σ on / filter |",
        "|---|---:|---:|---|---:|---:|---:|---|---|",
    ]
    totals: dict[str, list[float]] = {"off": [], "on": [], "filter": []}
    coverage: dict[str, list[float]] = {"on": [], "filter": []}
    for name in scenarios:
        for lat in LATENCIES:
            for lever in LEVERS:
                receiver = {
                    "gnss_rate_hz": 20.0, "gnss_doppler": False, "gnss_latency_s": lat,
                    "gnss_lever_offset_x": lever,
                }  # fmt: skip
                cfg = SensorConfig().with_overrides(_lookup(name).sensor_overrides).with_overrides(receiver)
                drive = simulate(name, seed=0, config=cfg)
                vehicle = load_vehicle(drive.meta["vehicle"])
                found = identify_latency(drive)
                ident = "–"
                if found is not None:  # the estimate, and what fused uses with its prior
                    ident = f"{found.latency_s:.3f} ± {found.sigma_s:.3f} → {found.posterior_mean(0.1):.3f}"
                cells = []
                shares, sigmas = [], []
                moving = np.hypot(drive["ref_vx"], drive["ref_vy"]) > SPEED_GATE
                # the smoother without and with the identified latency; the causal filter
                # never identifies it (it would read the whole drive)
                for method, key, on in (
                    ("fused", "off", False),
                    ("fused", "on", True),
                    ("fused_filter", "filter", True),
                ):
                    est = run_method(method, drive, vehicle, settings={"identify_gnss_latency": on})
                    value = metrics(drive, est.series)["beta_rmse_deg"]
                    totals[key].append(value)
                    cells.append(f"{value:.3f}")
                    if key != "off":
                        err = np.abs(est.series["beta"] - drive["ref_beta"])[moving]
                        std = est.series["beta_std"][moving]
                        shares.append(float(np.mean(err <= 2.0 * std)))
                        sigmas.append(float(np.degrees(np.median(std))))
                        coverage[key].append(shares[-1])
                cells.append(" / ".join(f"{v:.2f}" for v in shares))
                cells.append(" / ".join(f"{v:.3f}" for v in sigmas))
                lines.append(f"| {name} | {lat:g} | {lever:g} | {ident} | " + " | ".join(cells) + " |")
        print(f"{name}: done", flush=True)
    mean = {k: float(np.mean(v)) for k, v in totals.items()}
    lines += [
        "",
        f"Mean over the grid: fused {mean['off']:.3f} deg without the identified latency, "
        f"{mean['on']:.3f} with it; fused_filter {mean['filter']:.3f}.  Lowest share inside 2σ: "
        f"fused {min(coverage['on']):.2f}, fused_filter {min(coverage['filter']):.2f}.",
        "",
    ]
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--scenario", action="append", help="only this scenario (repeatable)")
    parser.add_argument("--out", type=Path, default=None, help="write here (default: the results file)")
    args = parser.parse_args()
    text = run(tuple(args.scenario) if args.scenario else SCENARIOS)
    out = args.out or (OUT if not args.scenario else None)
    if out is None:
        print(text)
    else:
        out.write_text(text)
        print(f"wrote {out}")


if __name__ == "__main__":
    main()
