"""A GNSS Doppler stamped late, and what the latency identified from it
(``sideslip.gnss_latency.identify_doppler_latency``: its speed against the wheels and its
course rate against the lateral accelerometer) does for ``fused``.

Every scenario's own receiver (fixes and Doppler, 10 Hz unless the scenario says otherwise),
each epoch reporting the truth 0 / 0.05 / 0.1 / 0.2 s before its stamp, as from a logger
that stamps messages on arrival.  Right vehicle file, seed 0; beta RMSE in degrees on rows faster
than 5 m/s, with the share of beta errors inside 2 beta_std in brackets.  "off": fused with
``identify_doppler_latency=false`` (the epochs taken at their stamps); "on": the default,
which takes each epoch at its stamp less the identified latency where the fit is decisive
(1-sigma at most 50 ms) and late by over 3 sigma; where it informs but does not decide, |r|
times the latency's rms about 0 (the fit with the prior N(0, 0.05 s)) enters beta_std.
fg_batch uses no Doppler; doppler_slip (like every paper method that reads GNSS) is handed
the epochs at their stamps less the latency where the same fits decide it
(``sideslip.doppler_timing``, ``run_method``).
Writes ``benchmarks/results/doppler_latency.md``.
Run: ``.venv/bin/python benchmarks/doppler_latency.py [--scenario S ...]``.
"""

from __future__ import annotations

import datetime as dt
from pathlib import Path

from compare_methods import two_sigma_share
from results_file import scenario_main

from sideslip.evaluate import metrics
from sideslip.methods.registry import run_method
from sideslip.simulate import SensorConfig, simulate
from sideslip.simulate.run import _lookup  # the scenario's own sensor overrides
from sideslip.vehicle import load_vehicle

OUT = Path(__file__).parent / "results" / "doppler_latency.md"
SCENARIOS = (
    "urban_course", "demo", "suburban_outages", "race_lap", "step_steer", "two_turns_gyro_sf",
    "slalom_low_mu", "dlc_bank", "cr_limit_slalom", "cr_limit_ramp",
)  # fmt: skip
LATENCIES = (0.0, 0.05, 0.1, 0.2)


def _cell(
    drive: object, method: str, vehicle: object, settings: dict[str, object] | None
) -> tuple[str, object]:
    est = run_method(method, drive, vehicle, settings)
    rmse = metrics(drive, est.series)["beta_rmse_deg"]
    share = two_sigma_share(drive, est) if method.startswith("fused") else None
    return (f"{rmse:.3f}" + (f" ({share:.2f})" if share is not None else "")), est


def run(scenarios: tuple[str, ...]) -> str:
    when = f"{dt.datetime.now(dt.UTC):%Y-%m-%d %H:%M}"
    about = " ".join(__doc__.split("\n\n")[1].split())
    header = (
        "| scenario | latency s | identified s | used s | fused off | fused on | fused_filter off "
        "| fused_filter on | doppler_slip | fg_batch |"
    )
    lines = ["# A late GNSS Doppler, and fused with its identified latency", ""]
    lines.append(f"Measured {when} UTC by `benchmarks/doppler_latency.py`.  {about}")
    lines += ["", header, "|---|---:|---|---:|---:|---:|---:|---:|---:|---:|"]
    for name in scenarios:
        for lat in LATENCIES:
            cfg = SensorConfig().with_overrides(_lookup(name).sensor_overrides)
            drive = simulate(name, seed=0, config=cfg.with_overrides({"gnss_latency_s": lat}))
            vehicle = load_vehicle(drive.meta["vehicle"])
            row = [name, f"{lat:g}"]
            cells = []
            params: dict[str, object] = {}
            for method in ("fused", "fused_filter"):
                off, _ = _cell(drive, method, vehicle, {"identify_doppler_latency": False})
                on, est = _cell(drive, method, vehicle, None)
                cells += [off, on]
                params = est.params
            ident = params.get("gnss_doppler_latency_identified_s")
            sigma = params.get("gnss_doppler_latency_identified_sigma_s")
            row.append("–" if ident is None else f"{ident:+.3f} ± {sigma:.3f}")
            row.append(f"{params.get('gnss_doppler_latency_s', 0.0):.3f}")
            row += [cells[0], cells[1], cells[2], cells[3]]
            row += [_cell(drive, m, vehicle, None)[0] for m in ("doppler_slip", "fg_batch")]
            lines.append("| " + " | ".join(row) + " |")
            print(lines[-1], flush=True)
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    scenario_main(__doc__, run, SCENARIOS, OUT)
