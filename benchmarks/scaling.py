"""How each method's cost grows with the drive's length: 10 min, 1 h, 4 h and 24 h at 100 Hz.

Every method runs on the benchmark drive (``sideslip.bench``: the ``endurance`` scenario,
simulated up to 1 h, repeated end to end beyond) of each length, in a fresh child process per
(method, length) so the peak memory is that method's alone: ``method MB`` is the high-water
mark of the child's resident set while the method runs minus the resident set just before
(interpreter, drive, compiled code), read from ``/proc/self/status``; time is the CPU time the
method used (all its threads), which the shared machine's load disturbs far less than the wall
clock (both are in the JSON).  A 24 h run is skipped where the 4 h run's memory, scaled
linearly, would pass ``--budget-gb``, or its CPU time, extrapolated with its growth exponent,
``--budget-s`` (the machine is shared).

Writes ``benchmarks/results/scaling.json`` (after every run, so a stopped run keeps what it
measured), ``scaling.md`` (table, growth exponents, methods over issue #17's bounds) and
``scaling.png`` (log-log: memory and time against hours).

    nice .venv/bin/python benchmarks/scaling.py [--hours 0.1667 1 4 24] [--method M ...]
"""

from __future__ import annotations

import argparse
import datetime as dt
import json
import math
import os
import platform
import time
from pathlib import Path
from typing import Any

from sideslip.bench import bench_drive, measure_in_subprocess
from sideslip.methods.registry import all_methods

RESULTS = Path(__file__).parent / "results"
HOURS = (1.0 / 6.0, 1.0, 4.0, 24.0)
MB_PER_HOUR_BOUND = 250.0  # issue #17: peak memory on the 1 h bench drive
MB_PER_DAY_BOUND = 4000.0  # issue #17: a 24 h, 100 Hz drive through every method in <= 4 GB
# (the whole process: interpreter, drive and method)
NONLINEAR_EXPONENT = 1.15  # memory or time growing faster than hours**1.15 is "nonlinear"


def _cpu(run: dict[str, Any]) -> float:
    return float(run.get("cpu_seconds", run["seconds"]))


def _label(hours: float) -> str:
    return f"{hours * 60:.0f} min" if hours < 1.0 else f"{hours:g} h"


def _exponent(runs: dict[float, dict[str, Any]], key: str) -> float:
    """Log-log slope of ``key`` against hours between the 1 h run and the longest run."""
    done = sorted(h for h, r in runs.items() if key in r and h >= 1.0 and r[key] > 0)
    if len(done) < 2:
        return math.nan
    a, b = done[0], done[-1]
    return math.log(runs[b][key] / runs[a][key]) / math.log(b / a)


def _markdown(result: dict[str, Any]) -> str:
    hours = result["hours"]
    lines = [
        "# Cost against drive length",
        "",
        f"Measured {result['date']} on {result['machine']} by `benchmarks/scaling.py` "
        f"({result['elapsed_s'] / 60:.0f} min).  Drive: `endurance` at 100 Hz "
        "(the 1 h simulation repeated end to end past 1 h).  Each cell: the method's own peak "
        "memory (MB, peak resident set of a child process while the method runs minus the "
        "process before it with the drive loaded) / CPU time (s).  `x_mem`, `x_time`: "
        "log-log growth exponent from 1 h to the longest run (1 = linear).",
        "",
        "| method | " + " | ".join(_label(h) for h in hours)
        + " | B/row 1 h | process GB, longest | x_mem | x_time | notes |",
        "|---|" + "---:|" * len(hours) + "---:|---:|---:|---:|---|",
    ]
    flagged: list[str] = []
    for name, runs_raw in result["methods"].items():
        runs = {float(h): r for h, r in runs_raw.items()}
        cells = []
        notes: list[str] = []
        for h in hours:
            r = runs.get(h)
            if r is None:
                cells.append("-")
            elif "skipped" in r or "error" in r:
                cells.append("n/a")
                notes.append(f"{_label(h)}: {r.get('skipped') or r.get('error')}")
            else:
                cells.append(f"{r['method_mb']:,.0f} / {_cpu(r):.1f}")
                if r.get("nonfinite"):
                    notes.append(f"{_label(h)}: non-finite {r['nonfinite']}")
        one = runs.get(1.0, {})
        per_row = f"{one['bytes_per_row']:,.0f}" if "bytes_per_row" in one else "-"
        x_mem = _exponent(runs, "method_mb")
        x_time = _exponent(runs, "cpu_seconds")
        if one.get("method_mb", 0.0) > MB_PER_HOUR_BOUND:
            notes.append(f"over {MB_PER_HOUR_BOUND:.0f} MB per 1 h")
        if runs.get(24.0, {}).get("peak_rss_mb", 0.0) > MB_PER_DAY_BOUND:
            notes.append(f"process over {MB_PER_DAY_BOUND / 1000:.0f} GB at 24 h")
        if x_mem > NONLINEAR_EXPONENT:
            notes.append("memory nonlinear")
        if x_time > NONLINEAR_EXPONENT:
            notes.append("time nonlinear")
        if notes:
            flagged.append(name)
        longest = max((h for h, r in runs.items() if "peak_rss_mb" in r), default=None)
        total = f"{runs[longest]['peak_rss_mb'] / 1024:.1f} ({_label(longest)})" if longest else "-"
        lines.append(
            f"| {name} | " + " | ".join(cells) + f" | {per_row} | {total} | "
            f"{x_mem:.2f} | {x_time:.2f} | {'; '.join(notes)} |".replace("nan", "-")
        )
    drive_gb = {
        h: r["drive_mb"] / 1024.0 for runs in result["methods"].values()
        for h, r in ((float(k), v) for k, v in runs.items()) if "drive_mb" in r
    }  # fmt: skip
    longest_drive = max(drive_gb, default=None)
    drive_text = (
        f"{drive_gb[longest_drive]:.2f} GB at {_label(longest_drive)}" if longest_drive else "-"
    )
    lines += [
        "",
        f"Methods over a bound or growing faster than linear: {', '.join(flagged) or 'none'}.",
        "",
        "Reading it: `process GB` is the whole child's peak (interpreter, the drive and the "
        "method; issue #17's bound: 4 GB at 24 h).  The drive is the compact one the methods "
        f"read (`Drive.compact`: no `ref_*` truth columns, sensor channels float32; {drive_text}"
        "; the full float64 drive with the reference is 2.3 GB at 24 h).  An `x_time` of 1.15-1.3 on runs of a few "
        "tenths of a second at 1 h is partly timer noise and partly the arrays outgrowing the CPU "
        "caches (memory-bound passes); an exponent well above that (doppler_slip's) is the "
        "algorithm.  Runs not made are listed with the projection that stopped them.",
        "",
        "![cost against drive length](scaling.png)",
    ]
    return "\n".join(lines) + "\n"


def _plot(result: dict[str, Any], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (ax_mem, ax_time) = plt.subplots(1, 2, figsize=(11.0, 4.2), dpi=100)
    for k, (name, runs_raw) in enumerate(result["methods"].items()):
        style = {"ls": "-" if k < 10 else "--", "marker": "o" if k < 10 else "s", "ms": 3, "lw": 1}
        runs = sorted((float(h), r) for h, r in runs_raw.items() if "method_mb" in r)
        if len(runs) < 2:
            continue
        hs = [h for h, _ in runs]
        # floors keep the log axes finite for the cheapest methods (below 0.1 MB, 0.1 ms)
        ax_mem.plot(hs, [max(r["method_mb"], 0.1) for _, r in runs], label=name, **style)
        ax_time.plot(hs, [max(_cpu(r), 1e-4) for _, r in runs], label=name, **style)
    for ax, ylabel in ((ax_mem, "method peak memory, MB"), (ax_time, "CPU time, s")):
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("drive length, h (100 Hz)")
        ax.set_ylabel(ylabel)
        ax.grid(True, which="both", lw=0.3)
    ax_mem.axhline(MB_PER_HOUR_BOUND, color="k", lw=0.6, ls="--")
    ax_mem.axhline(MB_PER_DAY_BOUND, color="r", lw=0.6, ls="--")
    handles, labels = ax_time.get_legend_handles_labels()
    fig.suptitle("sideslip: cost against drive length (dashed: 250 MB, 4 GB)", fontsize=9)
    fig.tight_layout(rect=(0.0, 0.0, 0.8, 1.0))
    fig.legend(handles, labels, fontsize=7, loc="center right", frameon=False)
    fig.savefig(path)
    plt.close(fig)


def _write(result: dict[str, Any], out: Path) -> None:
    out.mkdir(parents=True, exist_ok=True)
    (out / "scaling.json").write_text(json.dumps(result, indent=1))
    (out / "scaling.md").write_text(_markdown(result))
    _plot(result, out / "scaling.png")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--hours", type=float, nargs="+", default=list(HOURS))
    parser.add_argument("--method", action="append", default=None)
    parser.add_argument("--budget-gb", type=float, default=9.0, help="largest projected child RSS")
    parser.add_argument("--out", type=Path, default=RESULTS)
    parser.add_argument("--nice", type=int, default=0, help="extra niceness of each child")
    parser.add_argument("--budget-s", type=float, default=900.0, help="longest projected run time")
    parser.add_argument("--reuse", action="store_true", help="keep the runs already in scaling.json")
    args = parser.parse_args()
    start = time.perf_counter()
    bench_drive(1.0)  # simulate and cache the 1 h drive once, before the children need it
    names = args.method or list(all_methods())
    hours = sorted(args.hours)
    result: dict[str, Any] = {
        "date": dt.datetime.now(dt.UTC).isoformat(timespec="seconds"),
        "machine": f"{platform.machine()} ({os.cpu_count()} CPUs), Python {platform.python_version()}",
        "hours": hours,
        "budget_gb": args.budget_gb,
        "methods": {n: {} for n in names},
        "elapsed_s": 0.0,
    }
    old = args.out / "scaling.json"
    if args.reuse and old.exists():
        for name, runs_old in json.loads(old.read_text())["methods"].items():
            if name in result["methods"] or args.method:
                result["methods"][name] = {
                    float(h): r for h, r in runs_old.items() if "peak_rss_mb" in r and float(h) in hours
                }
    for h in hours:
        for name in names:
            result["methods"].setdefault(name, {})
            runs = result["methods"][name]
            if h in runs:
                continue
            done = [float(k) for k, r in runs.items() if "peak_rss_mb" in r]
            if runs and not done:
                continue  # skipped or failed on a shorter drive
            if done:
                last = max(done)
                # the process before the method (interpreter + drive) grows by the drive's size:
                # extrapolated from the two longest runs; the method's own peak scaled linearly
                before = runs[last]["rss_before_mb"]
                if len(done) > 1:
                    prev = sorted(done)[-2]
                    slope = (before - runs[prev]["rss_before_mb"]) / (last - prev)
                    before += max(slope, 0.0) * (h - last)
                else:
                    before *= h / last
                projected = before + runs[last]["method_mb"] * h / last
                if projected > args.budget_gb * 1024.0:
                    runs[h] = {"skipped": f"not run: projected {projected / 1024:.1f} GB"}
                    print(f"{_label(h):>7} {name:24s} skipped (projected {projected / 1024:.1f} GB)")
                    continue
                x_time = max(_exponent(runs, "cpu_seconds"), 1.0) if len(done) > 1 else 1.0
                x_time = x_time if math.isfinite(x_time) else 1.0
                secs = _cpu(runs[last]) * (h / last) ** x_time
                if secs > args.budget_s:
                    runs[h] = {"skipped": f"not run: projected {secs / 60:.0f} min"}
                    print(f"{_label(h):>7} {name:24s} skipped (projected {secs:.0f} s)")
                    continue
            r = measure_in_subprocess(name, h, nice=args.nice, timeout_s=3600.0)
            runs[h] = r
            if "method_mb" in r:
                print(
                    f"{_label(h):>7} {name:24s} {r['method_mb']:8.0f} MB {_cpu(r):8.2f} CPU-s "
                    f"{r['samples_per_s']:12,.0f}/s  nonfinite {r['nonfinite'] or 0}",
                    flush=True,
                )
            else:
                print(f"{_label(h):>7} {name:24s} {r}", flush=True)
            result["elapsed_s"] = time.perf_counter() - start
            _write(result, args.out)
    result["elapsed_s"] = time.perf_counter() - start
    _write(result, args.out)
    print(f"wrote {args.out / 'scaling.md'}")


if __name__ == "__main__":
    main()
