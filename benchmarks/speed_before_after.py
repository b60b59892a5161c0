"""CPU seconds of each method's own function on the 1 h bench drive, in this source tree.

Issue 13 point 8 asks the restructure to keep ``sideslip bench`` speeds within 10 %.  The bench
times the whole default pipeline (auto tuning, health, input checks), which later issues added
on purpose; this script times ``method.func`` alone, with ``--untuned`` the settings that
switch the added tuning and uncertainty passes off (``preset`` typical/physics, consistency
window and model-error terms 0), so that two trees can be compared on the same drive:

    PYTHONPATH=OLD/src  python benchmarks/speed_before_after.py DRIVE.parquet M1,M2 --tag before
    PYTHONPATH=NEW/src  python benchmarks/speed_before_after.py DRIVE.parquet M1,M2 --untuned

Prints one JSON object {method: best-of-N CPU seconds} (N = ``--repeat``, default 3).  The drive is the bench's cached
``endurance_1h.parquet`` (``sideslip bench`` writes it).
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import time
from typing import Any

from sideslip.drive import load_drive
from sideslip.methods.registry import all_methods
from sideslip.vehicle import load_vehicle

FILTER_PRESET = {"kkf", "mkf", "mkf_adaptive", "ekf_wss_sas", "ekf_wss_sas_imu"}
OFF_FIELDS = ("consistency_window_s", "stiffness_rel_sigma", "gyro_scale_rel_sigma")


def _settings(method: Any, untuned: bool) -> Any:
    if getattr(method, "settings", None) is None:
        return None
    fields = {f.name for f in dataclasses.fields(method.settings)}
    kw: dict[str, object] = {}
    if untuned:
        if "preset" in fields:
            kw["preset"] = "typical" if method.name in FILTER_PRESET else "physics"
        kw.update({f: 0.0 for f in OFF_FIELDS if f in fields})
    return method.settings(**kw)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("drive")
    ap.add_argument("methods", help="comma-separated method names")
    ap.add_argument("--untuned", action="store_true")
    ap.add_argument("--repeat", type=int, default=3, help="timed calls per method (best is kept); default 3")
    args = ap.parse_args()
    drive = load_drive(args.drive)
    vehicle = load_vehicle(drive.meta["vehicle"])
    out: dict[str, float] = {}
    for name in args.methods.split(","):
        method = all_methods()[name]
        st = _settings(method, args.untuned)

        def call(d: Any, method: Any = method, st: Any = st) -> Any:
            return method.func(d, vehicle, st) if st is not None else method.func(d, vehicle)

        call(drive.slice(0, 6000))  # compile and warm the caches
        best = float("inf")
        for _ in range(args.repeat):
            start = time.process_time()
            call(drive)
            best = min(best, time.process_time() - start)
        out[name] = round(best, 3)
    print(json.dumps(out))


if __name__ == "__main__":
    main()
