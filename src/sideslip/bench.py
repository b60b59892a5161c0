"""`sideslip bench`: samples per second and peak memory of every method on a long drive.

The benchmark drive is simulated once (``BENCH_SCENARIO``, stretched to the asked length up
to ``MAX_HOURS``; longer drives repeat the one-hour drive end to end, see :func:`tiled_drive`)
and cached in the user's cache folder (``$XDG_CACHE_HOME/sideslip/bench``, or ``--cache``).
Each method is first run on a one-minute slice (numba compilation and caches warm up), then
timed on the whole drive.  Its peak memory is measured in a child process of its own
(:func:`measure_in_subprocess`): the resident set before the method runs (interpreter, drive)
and the high-water mark while it runs (``VmHWM`` of ``/proc/self/status``, reset just before),
so buffers that numba or C libraries allocate count too (``tracemalloc`` sees only Python's).
Peer libraries (FilterPy, GTSAM) run the same model on the same data in the same process when
installed; their speed is shown as a ratio.  Results go to ``<out>/bench.json`` and
``bench.md`` when an output folder is given (``sideslip bench --out DIR``).
"""

from __future__ import annotations

import datetime as _dt
import gc
import importlib
import json
import os
import pkgutil
import platform
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
from rich.console import Console
from rich.table import Table

from sideslip.doppler_timing import forget_timings
from sideslip.drive import Drive, load_drive, save_drive
from sideslip.methods.registry import all_methods, run_method, why_not
from sideslip.vehicle import load_vehicle

BENCH_SCENARIO = "endurance"
MAX_HOURS = 1.25  # the endurance route is about 110 km long: longer drives are tiled
MAX_TILED_HOURS = 48.0
POSITION_COLUMNS = ("gnss_e", "gnss_n", "gnss_u", "ref_e", "ref_n", "ref_u")


def default_cache() -> Path:
    """Where benchmark drives are cached: ``$XDG_CACHE_HOME/sideslip/bench`` (~/.cache/...)."""
    base = os.environ.get("XDG_CACHE_HOME") or str(Path.home() / ".cache")
    return Path(base) / "sideslip" / "bench"


def tiled_drive(base: Drive, hours: float) -> Drive:
    """``base`` repeated end to end until ``hours`` long (rows on one uniform time base).

    Each copy starts one sample after the previous one ends; its positions (``gnss_*``,
    ``ref_*`` e/n/u) are shifted so the route goes on from where the last copy stopped.  The
    endurance drive starts and ends at a standstill, so the seam is a stop; the heading there
    jumps (the gyro does not see it), which matters to accuracy, not to cost.
    """
    dt = base.dt_median
    n_base = len(base)
    n = round(hours * 3600.0 / dt) + 1
    reps = -(-n // n_base)
    span = float(base.t[-1] - base.t[0]) + dt
    t = (base.t[None, :] - base.t[0] + span * np.arange(reps)[:, None]).ravel()[:n]
    data: dict[str, np.ndarray] = {}
    ref_shift = {c: base.data[c] for c in ("ref_e", "ref_n", "ref_u") if c in base.data}
    for name, col in base.data.items():
        out = np.tile(col, reps)[:n]
        axis = name[-1]
        ref = ref_shift.get(f"ref_{axis}") if name in POSITION_COLUMNS else None
        if ref is not None:
            finite = ref[np.isfinite(ref)]
            step = float(finite[-1] - finite[0]) if finite.size else 0.0
            out = out + np.repeat(step * np.arange(reps), n_base)[:n]
        data[name] = out
    meta = {**base.meta, "tiled_hours": hours, "tiled_from_rows": n_base}
    return Drive(t, data, meta, f"<{base.path} tiled to {hours:g} h>")


def bench_drive(
    hours: float, console: Console | None = None, cache: Path | None = None, reference: bool = True
) -> tuple[Drive, dict[str, float]]:
    """The cached benchmark drive of ``hours`` hours, and how long simulating/loading took.

    Up to ``MAX_HOURS`` the drive is simulated at that length; beyond, the one-hour drive is
    tiled (:func:`tiled_drive`) up to ``MAX_TILED_HOURS``.  ``reference=False`` gives the
    :meth:`~sideslip.drive.Drive.compact` drive (no ``ref_*`` truth columns, sensor channels
    float32) before tiling: what a method reads, and all a speed or memory measurement needs.
    """
    import sideslip.simulate as sim
    from sideslip.errors import InputError

    if not 0.0 < hours <= MAX_TILED_HOURS:
        raise InputError("--hours", f"{hours:g}: expected more than 0 and at most {MAX_TILED_HOURS:g} h")
    timings: dict[str, float]
    if hours > MAX_HOURS:
        base, timings = bench_drive(1.0, console, cache, reference)
        start = time.perf_counter()
        drive = tiled_drive(base, hours)
        timings["tile_s"] = time.perf_counter() - start
        timings["rows"] = float(len(drive))
        return drive, timings
    folder = cache if cache is not None else default_cache()
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / f"{BENCH_SCENARIO}_{hours:g}h.parquet"
    timings = {}
    if not path.exists():
        if console:
            console.print(f"simulating a {hours:g} h drive (cached in {path}) ...")
        start = time.perf_counter()
        drive = sim.simulate(BENCH_SCENARIO, seed=0, duration_s=hours * 3600.0)
        timings["simulate_s"] = time.perf_counter() - start
        save_drive(drive, path)
    start = time.perf_counter()
    drive = load_drive(path, compact=not reference)
    timings["load_parquet_s"] = time.perf_counter() - start
    timings["rows"] = float(len(drive))
    timings["columns"] = float(len(list(drive.columns())))
    return drive, timings


def _status_kb(key: str) -> float:
    """A ``/proc/self/status`` entry in kB (NaN where there is no /proc)."""
    try:
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith(key + ":"):
                return float(line.split()[1])
    except OSError:
        pass
    return float("nan")


def _release_free_memory() -> None:
    """Hand freed heap back to the system (glibc ``malloc_trim``, Arrow's pool), so the resident
    set before a method runs holds no free memory its allocations could hide in."""
    import ctypes
    import ctypes.util

    gc.collect()
    try:
        import pyarrow as pa

        pa.default_memory_pool().release_unused()
    except (ImportError, AttributeError):
        pass
    name = ctypes.util.find_library("c")
    if name:
        try:
            ctypes.CDLL(name).malloc_trim(0)
        except (OSError, AttributeError):
            pass


def _reset_peak() -> bool:
    """Reset the resident-set high-water mark (Linux ``clear_refs`` 5); False where it cannot."""
    try:
        Path("/proc/self/clear_refs").write_text("5")
    except OSError:
        return False
    return True


def measure_method(name: str, hours: float, cache: Path | None = None) -> dict[str, Any]:
    """Run method ``name`` on the ``hours`` drive in this process: time, peak RSS, finiteness.

    Meant for a fresh child process (:func:`measure_in_subprocess`): ``rss_before_mb`` is the
    process with the drive loaded and the method compiled (warm-up on a one-minute slice),
    ``peak_rss_mb`` the high-water mark while the method runs, ``method_mb`` their difference.
    The drive holds what the methods read (:meth:`~sideslip.drive.Drive.compact`: no ``ref_*``
    truth columns, sensor channels in float32); ``drive_mb`` is its size.
    """
    import resource

    drive, _ = bench_drive(hours, None, cache, reference=False)
    vehicle = load_vehicle(drive.meta["vehicle"])
    method = all_methods()[name]
    reason = why_not(method, drive, vehicle)
    if reason:
        return {"method": name, "hours": hours, "skipped": reason}
    warm = drive.slice(0, min(len(drive), int(60.0 / max(drive.dt_median, 1e-3))))
    run_method(method, warm, vehicle)
    del warm
    _release_free_memory()
    rss_before = _status_kb("VmRSS")
    exact = _reset_peak()
    start, cpu_start = time.perf_counter(), time.process_time()
    est = _cold_run(method, drive, vehicle)
    seconds = time.perf_counter() - start
    cpu_seconds = time.process_time() - cpu_start
    peak = _status_kb("VmHWM") if exact else resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    nonfinite = {
        k: int(np.size(v) - np.count_nonzero(np.isfinite(v)))
        for k, v in est.series.items()
        if np.size(v) and not k.endswith("health")
    }
    n = len(drive)
    return {
        "method": name,
        "hours": hours,
        "rows": n,
        "seconds": seconds,
        "samples_per_s": n / seconds,
        "cpu_seconds": cpu_seconds,
        "samples_per_cpu_s": n / max(cpu_seconds, 1e-9),
        "rss_before_mb": rss_before / 1024.0,
        "peak_rss_mb": peak / 1024.0,
        "method_mb": (peak - rss_before) / 1024.0,
        "bytes_per_row": (peak - rss_before) * 1024.0 / n,
        "peak_exact": exact,
        "drive_mb": drive.nbytes() / 2**20,
        "nonfinite": {k: v for k, v in nonfinite.items() if v},
    }


def measure_in_subprocess(
    name: str, hours: float, cache: Path | None = None, timeout_s: float = 3600.0, nice: int = 0
) -> dict[str, Any]:
    """:func:`measure_method` in a fresh Python process (its memory is the method's alone)."""
    args = json.dumps({"method": name, "hours": hours, "cache": str(cache) if cache else None})
    cmd = [sys.executable, "-m", "sideslip.bench", args]
    if nice:
        cmd = ["nice", "-n", str(nice), *cmd]
    try:
        proc = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout_s, check=False)
    except subprocess.TimeoutExpired:
        return {"method": name, "hours": hours, "error": f"timed out after {timeout_s:g} s"}
    lines = [ln for ln in proc.stdout.splitlines() if ln.startswith("{")]
    if proc.returncode != 0 or not lines:
        tail = (proc.stderr.strip().splitlines() or [f"exit {proc.returncode}"])[-1]
        return {"method": name, "hours": hours, "error": f"exit {proc.returncode}: {tail}"}
    result: dict[str, Any] = json.loads(lines[-1])
    return result


def _peers() -> dict[str, list[Any]]:
    """method name -> peer modules (``sideslip.peers.*`` with PEER_FOR, NAME, run)."""
    out: dict[str, list[Any]] = {}
    try:
        import sideslip.peers as pkg
    except ImportError:
        return out
    for info in pkgutil.iter_modules(pkg.__path__):
        try:
            mod = importlib.import_module(f"sideslip.peers.{info.name}")
        except ImportError:
            continue  # the peer library is not installed
        for method in getattr(mod, "PEER_FOR", ()):
            out.setdefault(method, []).append(mod)
    return out


def _timed(func: Any, *args: Any) -> tuple[float, Any]:
    wall, _, result = _timed_cpu(func, *args)
    return wall, result


def _cold_run(method: Any, drive: Any, vehicle: Any) -> Any:
    """``run_method`` as on a drive seen for the first time: the Doppler's timing, which
    ``estimate`` fits once for all the methods of a drive, is fitted again."""
    forget_timings()
    return run_method(method, drive, vehicle)


def _timed_cpu(func: Any, *args: Any) -> tuple[float, float, Any]:
    """Wall-clock and CPU seconds (this process, all threads) of ``func(*args)``."""
    gc.collect()
    start, cpu = time.perf_counter(), time.process_time()
    result = func(*args)
    return time.perf_counter() - start, time.process_time() - cpu, result


def run_bench(
    hours: float = 1.0,
    methods: list[str] | None = None,
    console: Console | None = None,
    memory: bool = True,
    out_dir: Path | None = None,
    cache: Path | None = None,
    repeat: int = 3,
) -> dict[str, Any]:
    """Time every (or the named) method; print a table; write ``out_dir``/bench.* if given.

    Each method runs ``repeat`` times on the drive and the fastest run is reported (as
    :mod:`timeit` does: slower runs measure the machine's other load, not the method)."""
    console = console or Console()
    load_at_start = os.getloadavg()
    if out_dir is not None:
        _check_out_dir(out_dir)
    drive, timings = bench_drive(hours, console, cache, reference=False)
    vehicle = load_vehicle(drive.meta["vehicle"])
    n = len(drive)
    warm = drive.slice(0, min(n, int(60.0 / max(drive.dt_median, 1e-3))))
    registry = all_methods()
    peers = _peers()
    rows: list[dict[str, Any]] = []
    for name, method in registry.items():
        if methods and name not in methods:
            continue
        reason = why_not(method, drive, vehicle)
        if reason:
            rows.append({"method": name, "skipped": reason})
            continue
        run_method(method, warm, vehicle)
        runs = [_timed_cpu(_cold_run, method, drive, vehicle)[:2] for _ in range(max(repeat, 1))]
        elapsed, cpu = min(runs)
        row: dict[str, Any] = {
            "method": name,
            "seconds": elapsed,
            "samples_per_s": n / elapsed,
            "cpu_seconds": cpu,
            "samples_per_cpu_s": n / max(cpu, 1e-9),
            "runs_seconds": [r[0] for r in runs],
        }
        if memory:
            mem = measure_in_subprocess(name, hours, cache)
            if "error" in mem:
                row["memory_error"] = mem["error"]
            else:
                row["peak_mb"] = mem["method_mb"]
                row["bytes_per_row"] = mem["bytes_per_row"]
                row["peak_rss_mb"] = mem["peak_rss_mb"]
        for peer in peers.get(name, []):
            peer.run(warm, vehicle)
            p_elapsed, _ = _timed(peer.run, drive, vehicle)
            row.setdefault("peers", []).append(
                {
                    "peer": peer.NAME,
                    "seconds": p_elapsed,
                    "samples_per_s": n / p_elapsed,
                    "speed_ratio": p_elapsed / elapsed,
                }
            )
        rows.append(row)
        console.print(f"  {name}: {n / elapsed:,.0f} samples/s")
    result = {
        "date": _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds"),
        "machine": {
            "platform": platform.platform(),
            "processor": platform.processor() or platform.machine(),
            "cpus": os.cpu_count(),
            "python": platform.python_version(),
            "load_average": [round(x, 2) for x in load_at_start],
        },
        "drive": {"scenario": BENCH_SCENARIO, "hours": hours, **timings},
        "repeat": max(repeat, 1),
        "methods": rows,
    }
    _print(console, result)
    if out_dir is None:
        console.print("results printed only: --out DIR writes bench.json and bench.md")
        return result
    from sideslip.drive import _atomic_write

    out_dir.mkdir(parents=True, exist_ok=True)
    _atomic_write(out_dir / "bench.json", lambda tmp: tmp.write_text(json.dumps(result, indent=2)))
    _atomic_write(out_dir / "bench.md", lambda tmp: tmp.write_text(_markdown(result)))
    console.print(f"wrote {out_dir / 'bench.json'} and {out_dir / 'bench.md'}")
    return result


def _check_out_dir(out_dir: Path) -> None:
    """Refuse an output folder that is a file or cannot be written, before anything runs."""
    from sideslip.errors import InputError

    if out_dir.exists() and not out_dir.is_dir():
        raise InputError(str(out_dir), "--out: expected a folder, found a file")
    probe = out_dir
    while not probe.exists():
        probe = probe.parent
    if not os.access(probe, os.W_OK | os.X_OK):
        raise InputError(str(out_dir), "--out: the folder cannot be written")


def _peer_text(row: dict[str, Any]) -> str:
    parts = []
    for p in row.get("peers", []):
        parts.append(f"{p['peer']}: {p['samples_per_s']:,.0f}/s (ours {p['speed_ratio']:.1f}x faster)")
    return "; ".join(parts) or "-"


def _print(console: Console, result: dict[str, Any]) -> None:
    d = result["drive"]
    table = Table(title=f"sideslip bench: {d['hours']:g} h drive, {int(d['rows']):,} rows")
    for col in ("method", "samples/s", "seconds", "peak MB", "B/row", "peer library"):
        table.add_column(col, justify="left" if col in ("method", "peer library") else "right")
    for row in result["methods"]:
        if "skipped" in row:
            table.add_row(row["method"], "-", "-", "-", "-", f"skipped: {row['skipped']}")
            continue
        table.add_row(
            row["method"],
            f"{row['samples_per_s']:,.0f}",
            f"{row['seconds']:.2f}",
            f"{row['peak_mb']:.0f}" if "peak_mb" in row else "-",
            f"{row['bytes_per_row']:,.0f}" if "bytes_per_row" in row else "-",
            _peer_text(row),
        )
    console.print(table)
    extra = [f"load parquet {d['load_parquet_s']:.2f} s"]
    if "simulate_s" in d:
        extra.append(f"simulate {d['simulate_s']:.1f} s")
    console.print("drive: " + ", ".join(extra))


def _markdown(result: dict[str, Any]) -> str:
    d = result["drive"]
    m = result["machine"]
    lines = [
        "# sideslip bench results",
        "",
        f"Measured {result['date']} on {m['processor']} ({m['cpus']} CPUs), Python {m['python']}"
        + (f"; load average {m['load_average'][0]:.1f} at the start (a shared machine: "
           "samples/s scale with the CPU left)" if m.get("load_average") else "")
        + ".",
        f"Drive: scenario `{d['scenario']}`, {d['hours']:g} h, {int(d['rows']):,} rows, "
        f"{int(d['columns'])} columns; Parquet load {d['load_parquet_s']:.2f} s"
        + (f"; simulation {d['simulate_s']:.1f} s" if "simulate_s" in d else "")
        + ".",
        "",
        f"samples/s: the fastest of {result.get('repeat', 1)} runs on the drive (slower runs measure",
        "the machine's other load); samples/CPU-s: rows per second of CPU time that run used",
        "(all its threads), which a shared machine's load disturbs less than samples/s.",
        "Peak MB: the method's own peak resident memory (high-water mark of the process while",
        "it runs minus the process before it, with the drive loaded), measured in a child process",
        "per method; B/row: that peak per drive row.  Issue #17's bound: 250 MB per 1 h drive.",
        "",
        "| method | samples/s | samples/CPU-s | seconds | peak MB | B/row | peer library |",
        "|---|---:|---:|---:|---:|---:|---|",
    ]
    for row in result["methods"]:
        if "skipped" in row:
            lines.append(f"| {row['method']} | - | - | - | - | - | skipped: {row['skipped']} |")
        else:
            peak = f"{row['peak_mb']:.0f}" if "peak_mb" in row else "-"
            per_row = f"{row['bytes_per_row']:,.0f}" if "bytes_per_row" in row else "-"
            cpu = f"{row['samples_per_cpu_s']:,.0f}" if "samples_per_cpu_s" in row else "-"
            lines.append(
                f"| {row['method']} | {row['samples_per_s']:,.0f} | {cpu} | {row['seconds']:.2f} | "
                f"{peak} | {per_row} | {_peer_text(row)} |"
            )
    return "\n".join(lines) + "\n"


def _child_main(argv: list[str]) -> None:
    """``python -m sideslip.bench '{"method": ..., "hours": ...}'``: one measurement as JSON."""
    args = json.loads(argv[0])
    cache = Path(args["cache"]) if args.get("cache") else None
    print(json.dumps(measure_method(args["method"], float(args["hours"]), cache)), flush=True)


if __name__ == "__main__":
    _child_main(sys.argv[1:])
