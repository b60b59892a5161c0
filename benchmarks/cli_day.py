"""Whole-process peak memory of ``sideslip estimate`` on a day-long drive (issue 17, point 1).

``benchmarks/scaling.py`` measures each method alone, inside one process that already holds
the drive.  This is what a user runs: ``sideslip estimate DAY.parquet --method M --out ...``
in a fresh process, load and write included, on the bench's 24 h, 100 Hz drive (the 1 h
``endurance`` simulation tiled, saved as Parquet with its ``ref_*`` columns as a user's drive
would be; 1.4 GB on disk, cached beside the bench drives).  The peak is the child's
``VmHWM``; issue 17's bound is 4 GB.

    nice .venv/bin/python benchmarks/cli_day.py [--hours 24] [--method M ...] [--out FILE.md] [--reuse]

Every run is kept in ``FILE.json`` beside the table; ``--reuse`` keeps the runs recorded there
for methods not named again (the table lists them all, each with the time it was measured).
"""

from __future__ import annotations

import argparse
import datetime as dt
import json
import platform
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from sideslip.bench import bench_drive, default_cache
from sideslip.drive import save_drive

RESULTS = Path(__file__).parent / "results"
BOUND_GB = 4.0
# The child runs the command line in-process and reports its own high-water mark at exit.
CHILD = """
import atexit, sys
from pathlib import Path
def report():
    for line in Path('/proc/self/status').read_text().splitlines():
        if line.startswith('VmHWM:'):
            sys.stderr.write('VMHWM_KB ' + line.split()[1] + '\\n')
atexit.register(report)
from sideslip.cli.app import main
sys.argv = ['sideslip', *sys.argv[1:]]
main()
"""


def day_drive(hours: float) -> Path:
    path = default_cache() / f"endurance_{hours:g}h_full.parquet"
    if not path.exists():
        drive, _ = bench_drive(hours, reference=True)
        save_drive(drive, path)
    return path


def run(path: Path, method: str, vehicle: str) -> dict[str, float | str]:
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "est.parquet"
        args = ["-q", "estimate", str(path), "--vehicle", vehicle, "--method", method, "--out", str(out)]
        start = time.perf_counter()
        proc = subprocess.run([sys.executable, "-c", CHILD, *args], capture_output=True, text=True)
        wall = time.perf_counter() - start
        kb = [float(x.split()[1]) for x in proc.stderr.splitlines() if x.startswith("VMHWM_KB")]
        if proc.returncode != 0 or not kb:
            said = [x for x in proc.stderr.splitlines() if x.strip() and not x.startswith("VMHWM_KB")]
            return {"method": method, "error": (said or ["no output"])[-1][:200]}
        return {"method": method, "peak_gb": kb[-1] * 1024 / 1e9, "wall_s": wall,
                "out_mb": out.stat().st_size / 1e6,
                "measured": f"{dt.datetime.now(dt.UTC):%Y-%m-%d %H:%M}"}  # fmt: skip


def markdown(rows: list[dict[str, float | str]], hours: float, path: Path) -> str:
    lines = [
        f"# `sideslip estimate` on a {hours:g} h drive: whole-process peak memory",
        "",
        f"Measured {dt.datetime.now(dt.UTC):%Y-%m-%d %H:%M} UTC on {platform.machine()} by "
        "`benchmarks/cli_day.py`: a fresh `sideslip estimate DRIVE --method M` per row, reading "
        f"`{path.name}` ({path.stat().st_size / 1e9:.2f} GB Parquet, 100 Hz, with its `ref_*` "
        "columns) and writing the estimate; peak = the process's `VmHWM` (GB = 1e9 bytes). "
        "The drive is read compact (over 2,000,000 rows). Wall time on the shared 2-core machine.",
        "",
        "| method | peak GB | wall s | estimate file MB | within 4 GB | measured (UTC) |",
        "|---|---:|---:|---:|---|---|",
    ]
    for r in rows:
        if "error" in r:
            lines.append(f"| {r['method']} | - | - | - | failed: {r['error']} |")
            continue
        ok = "yes" if float(r["peak_gb"]) <= BOUND_GB else "**no**"
        lines.append(
            f"| {r['method']} | {r['peak_gb']:.2f} | {r['wall_s']:.0f} | {r['out_mb']:.0f} | {ok} "
            f"| {r.get('measured', '-')} |"
        )
    return "\n".join(lines) + "\n"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--hours", type=float, default=24.0)
    ap.add_argument("--method", action="append", required=True)
    ap.add_argument("--vehicle", default="midsize_sedan")
    ap.add_argument("--out", type=Path, default=RESULTS / "cli_day.md")
    ap.add_argument("--reuse", action="store_true", help="keep the recorded runs of other methods")
    args = ap.parse_args()
    path = day_drive(args.hours)
    store = args.out.with_suffix(".json")
    kept = json.loads(store.read_text()) if args.reuse and store.exists() else {}
    runs: dict[str, dict[str, float | str]] = {m: r for m, r in kept.items() if m not in args.method}
    for method in args.method:
        runs[method] = run(path, method, args.vehicle)
        print(json.dumps(runs[method]), flush=True)
        store.write_text(json.dumps(runs, indent=1))
        args.out.write_text(markdown([runs[m] for m in sorted(runs)], args.hours, path))
    print(f"wrote {args.out} and {store}")


if __name__ == "__main__":
    main()
