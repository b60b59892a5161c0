"""Fleet-scale runs: estimate (and evaluate, where there is a reference) over many drives.

Each drive is an independent job: load and validate, run the methods, write
``<out>/<stem>_est.parquet`` (+ ``.params.json``), compute metrics.  Jobs run in worker
processes (``concurrent.futures``) or on a Dask cluster (optional extra ``fleet``).  A drive
that fails validation is reported with its one-line error and the batch goes on; the summary
(``<out>/summary.csv`` and ``summary.json``: one row per drive and method) is written at the
end, atomically.
"""

from __future__ import annotations

import json
import os
import time
from collections.abc import Callable, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pandas as pd

from sideslip.drive import _atomic_write, load_drive
from sideslip.errors import InputError


@dataclass(frozen=True)
class JobResult:
    """Outcome of one drive: metrics per method, or the error line that stopped it."""

    drive: str
    rows: int = 0
    seconds: float = 0.0
    methods: tuple[str, ...] = ()
    skipped: dict[str, str] = field(default_factory=dict)
    metrics: dict[str, dict[str, float]] = field(default_factory=dict)
    error: str | None = None


def run_one(drive_path: str, vehicle: str, out_dir: str, methods: Sequence[str] | None) -> JobResult:
    """Estimate and evaluate one drive (runs in a worker; never raises for bad input)."""
    from sideslip.estimate import save_estimates
    from sideslip.evaluate import evaluate_all
    from sideslip.methods.registry import all_methods, run_method, why_not
    from sideslip.vehicle import load_vehicle

    start = time.perf_counter()
    try:
        veh = load_vehicle(vehicle)
        drive = load_drive(drive_path)
        registry = all_methods()
        chosen = [registry[m] for m in methods] if methods else list(registry.values())
        estimates = []
        skipped: dict[str, str] = {}
        for m in chosen:
            reason = why_not(m, drive, veh)
            if reason is None:
                estimates.append(run_method(m, drive, veh))
            else:
                skipped[m.name] = reason
        if not estimates:
            raise InputError(
                drive_path,
                "no method can run on this drive: " + "; ".join(f"{k}: {v}" for k, v in skipped.items()),
            )
        out = Path(out_dir) / f"{Path(drive_path).stem}_est.parquet"
        save_estimates(drive.t, estimates, out, {"drive": drive_path, "vehicle": vehicle})
        has_ref = any(c.startswith("ref_") for c in drive.columns())
        results = evaluate_all(drive, {e.method: dict(e.series) for e in estimates}) if has_ref else {}
        return JobResult(
            drive_path, len(drive), time.perf_counter() - start,
            tuple(e.method for e in estimates), skipped, results,
        )  # fmt: skip
    except InputError as exc:
        return JobResult(drive_path, seconds=time.perf_counter() - start, error=str(exc))


def summary_frame(results: Sequence[JobResult]) -> pd.DataFrame:
    """One row per (drive, method) with its metrics; failed drives get one row with the error."""
    rows: list[dict[str, Any]] = []
    for r in results:
        if r.error is not None:
            rows.append({"drive": r.drive, "method": "", "error": r.error})
            continue
        for method in r.methods:
            rows.append(
                {
                    "drive": r.drive,
                    "method": method,
                    "rows": r.rows,
                    "seconds": r.seconds,
                    **r.metrics.get(method, {}),
                }
            )
    return pd.DataFrame(rows)


def run_batch(
    drives: Sequence[str],
    vehicle: str,
    out_dir: str | Path,
    methods: Sequence[str] | None = None,
    workers: int | None = None,
    use_dask: bool = False,
    progress: Callable[[JobResult], None] | None = None,
) -> list[JobResult]:
    """Run every drive; write ``summary.csv``/``summary.json`` into ``out_dir``; return results."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    jobs = [str(d) for d in drives]
    results: list[JobResult] = []
    if use_dask:
        from dask.distributed import Client, LocalCluster
        from dask.distributed import as_completed as dask_completed

        with (
            LocalCluster(
                n_workers=workers or os.cpu_count() or 1,
                threads_per_worker=1,
                processes=True,
                dashboard_address=None,
            ) as cluster,
            Client(cluster) as client,
        ):
            futures = [client.submit(run_one, d, vehicle, str(out), methods, pure=False) for d in jobs]
            for fut in dask_completed(futures):
                res = fut.result()
                results.append(res)
                if progress:
                    progress(res)
    elif (workers or 1) == 1:
        for d in jobs:
            res = run_one(d, vehicle, str(out), methods)
            results.append(res)
            if progress:
                progress(res)
    else:
        with ProcessPoolExecutor(max_workers=workers) as pool:
            futs = [pool.submit(run_one, d, vehicle, str(out), methods) for d in jobs]
            for fut in as_completed(futs):
                res = fut.result()
                results.append(res)
                if progress:
                    progress(res)
    results.sort(key=lambda r: jobs.index(r.drive))
    frame = summary_frame(results)
    _atomic_write(out / "summary.csv", lambda tmp: frame.to_csv(tmp, index=False, float_format="%.6g"))
    payload = [
        {
            "drive": r.drive,
            "rows": r.rows,
            "seconds": r.seconds,
            "methods": list(r.methods),
            "skipped": r.skipped,
            "metrics": r.metrics,
            "error": r.error,
        }
        for r in results
    ]
    _atomic_write(out / "summary.json", lambda tmp: tmp.write_text(json.dumps(payload, indent=2)))
    return results
