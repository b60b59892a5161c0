"""How long one unidentified receiver latency / antenna lever-arm offset lasts in ``fused``'s
noise model for positions-only GNSS (``FusedSettings.gnss_offset_span_s``), measured.

Every simulated scenario of the comparison, seed 0, 20 Hz fixes without Doppler; the receiver
50 ms late with its antenna 0.5 m ahead of, 0.5 m behind, or where the vehicle file says, and
150 ms late with the antenna where the file says; the right, 30 %-soft and rough vehicle files
(compare_methods.FILES).  An antenna ahead of the file acts like a negative latency of l_x / v,
so 50 ms late and 0.5 m ahead nearly cancel (at 10 m/s exactly): that cell is the favourable
one, the others are not.  Per cell: ``fused``'s mean beta RMSE (deg, rows faster than 5 m/s)
over the scenarios and its lowest 2-sigma share, for each span.
Writes ``benchmarks/results/positions_offset_span.md``.
Run: ``.venv/bin/python benchmarks/positions_offset_span.py [--spans 1,3,10,20] [--file right ...]``.
"""

from __future__ import annotations

import argparse
import datetime as dt
import math
import time
from pathlib import Path

import numpy as np
from compare_methods import FILES, SCENARIOS, two_sigma_share

from sideslip.evaluate import metrics
from sideslip.methods.registry import run_method
from sideslip.simulate import SensorConfig, simulate
from sideslip.simulate.run import _lookup
from sideslip.vehicle import load_vehicle

OUT = Path(__file__).parent / "results" / "positions_offset_span.md"
SIMULATED = tuple(s for s in SCENARIOS if not s.startswith("revs"))
# (latency s, antenna ahead of the file m)
RECEIVERS = ((0.05, 0.5), (0.05, -0.5), (0.05, 0.0), (0.15, 0.0))


def run_cell(
    file_key: str, latency_s: float, lever_m: float, spans: list[float]
) -> dict[float, tuple[float, float]]:
    """span -> (fused's mean beta RMSE over the scenarios, its lowest 2-sigma share)."""
    rmse: dict[float, list[float]] = {s: [] for s in spans}
    share: dict[float, list[float]] = {s: [] for s in spans}
    receiver = {"gnss_rate_hz": 20.0, "gnss_doppler": False, "gnss_latency_s": latency_s,
                "gnss_lever_offset_x": lever_m}  # fmt: skip
    for name in SIMULATED:
        config = SensorConfig().with_overrides(_lookup(name).sensor_overrides).with_overrides(receiver)
        drive = simulate(name, seed=0, config=config)
        vehicle = FILES[file_key][1](load_vehicle(drive.meta["vehicle"]))
        for span in spans:
            est = run_method("fused", drive, vehicle, settings={"gnss_offset_span_s": span})
            rmse[span].append(metrics(drive, est.series)["beta_rmse_deg"])
            share[span].append(float(two_sigma_share(drive, est) or math.nan))
    return {s: (float(np.mean(rmse[s])), float(np.nanmin(share[s]))) for s in spans}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--spans", default="1,3,10,20,40", help="gnss_offset_span_s values, s")
    parser.add_argument("--file", action="append", choices=sorted(FILES), help="vehicle file (repeatable)")
    args = parser.parse_args()
    spans = [float(s) for s in args.spans.split(",")]
    files = args.file or ["right", "soft", "rough"]
    start = time.perf_counter()
    intro = " ".join(__doc__.split("\n\n")[1].split())
    lines = [
        "# fused, positions only: the correlation span of an unidentified latency / lever-arm offset",
        "",
        f"Measured {dt.datetime.now(dt.UTC):%Y-%m-%d %H:%M} UTC by `benchmarks/positions_offset_span.py`.  {intro}",
        "",
        "| file | latency s | antenna ahead m | " + " | ".join(f"span {s:g} s" for s in spans) + " |",
        "|---|---:|---:|" + "---:|" * len(spans),
    ]
    per_span: dict[str, dict[float, list[float]]] = {f: {s: [] for s in spans} for f in files}
    for file_key in files:
        for latency_s, lever_m in RECEIVERS:
            cell = run_cell(file_key, latency_s, lever_m, spans)
            for s in spans:
                per_span[file_key][s].append(cell[s][0])
            lines.append(f"| {file_key} | {latency_s:g} | {lever_m:+g} | "
                         + " | ".join(f"{cell[s][0]:.4f} ({cell[s][1]:.2f})" for s in spans) + " |")  # fmt: skip
            print(lines[-1], flush=True)
    lines += ["", "Cells: mean beta RMSE (deg) over the 16 scenarios (lowest 2-sigma share).  Mean over the "
              "four receivers, and the worst of them:", "",
              "| file | " + " | ".join(f"span {s:g} s" for s in spans) + " |", "|---|" + "---:|" * len(spans)]  # fmt: skip
    for file_key in files:
        lines.append(f"| {file_key} | "
                     + " | ".join(f"{np.mean(per_span[file_key][s]):.4f} / {max(per_span[file_key][s]):.4f}"
                                  for s in spans) + " |")  # fmt: skip
    lines += ["", f"Run time {time.perf_counter() - start:.0f} s."]
    OUT.write_text("\n".join(lines) + "\n")
    print(f"wrote {OUT}")


if __name__ == "__main__":
    main()
