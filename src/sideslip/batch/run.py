"""Run a fleet's drives: in this process, a process pool, a local Dask cluster, or a running one.

:func:`run_batch` names every drive's outputs (:func:`~sideslip.batch.naming.output_keys`),
runs one :func:`~sideslip.batch.job.run_job` per drive on the chosen engine, and writes into
the output folder (a local path or an fsspec URL): ``summary.csv`` / ``summary.json`` (one row
per drive and method), ``aggregate.parquet`` (per method, :mod:`sideslip.batch.aggregate`).
With ``scheduler="tcp://host:port"`` the jobs go to that Dask cluster; its workers must import
this sideslip and read the drives' paths or URLs.  Dask re-runs the jobs of a worker that dies;
a job is idempotent, so each drive still ends with one set of outputs.
"""

from __future__ import annotations

import json
import os
import uuid
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from typing import Any

from sideslip.batch import storage
from sideslip.batch.aggregate import aggregate_frame, summary_frame
from sideslip.batch.job import JobResult, JobSpec, run_job
from sideslip.batch.naming import output_keys
from sideslip.errors import InputError


def _dask_results(client: Any, specs: list[JobSpec]) -> Iterator[JobResult]:
    from dask.distributed import as_completed as dask_completed

    batch = uuid.uuid4().hex[:12]  # keys unique per batch: a cluster never hands back another's result
    futures = [
        client.submit(run_job, s, pure=False, key=f"sideslip-{batch}-{i}") for i, s in enumerate(specs)
    ]
    for fut in dask_completed(futures):
        yield fut.result()


def _connect(scheduler: str, timeout_s: float) -> Any:
    try:
        from dask.distributed import Client
    except ImportError:
        raise InputError(
            "--scheduler", "dask.distributed is not installed: pip install 'sideslip[fleet]'"
        ) from None
    try:
        return Client(scheduler, timeout=timeout_s)
    except (OSError, TimeoutError, ValueError) as exc:
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise InputError("--scheduler", f"cannot reach the Dask scheduler at {scheduler}: {first}") from None


def _results(
    specs: list[JobSpec], workers: int, use_dask: bool, scheduler: str | None, timeout_s: float
) -> Iterator[JobResult]:
    if scheduler:
        with _connect(scheduler, timeout_s) as client:
            yield from _dask_results(client, specs)
    elif use_dask:
        from dask.distributed import Client, LocalCluster

        with (
            LocalCluster(
                n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None
            ) as cl,
            Client(cl) as client,
        ):
            yield from _dask_results(client, specs)
    elif workers == 1:
        for s in specs:
            yield run_job(s)
    else:
        with ProcessPoolExecutor(max_workers=workers) as pool:
            for fut in as_completed([pool.submit(run_job, s) for s in specs]):
                yield fut.result()


def check_out_dir(out_dir: str) -> None:
    """Refuse an output folder that is a file (before any drive runs)."""
    if storage.exists(out_dir) and not storage.is_dir(out_dir):
        raise InputError(out_dir, "--out-dir: expected a folder, found a file")


def run_batch(
    drives: Sequence[str],
    vehicle: str,
    out_dir: str | os.PathLike[str],
    methods: Sequence[str] | None = None,
    workers: int | None = None,
    use_dask: bool = False,
    progress: Callable[[JobResult], None] | None = None,
    *,
    scheduler: str | None = None,
    resume: bool = False,
    settings: dict[str, Any] | None = None,
    connect_timeout_s: float = 10.0,
) -> list[JobResult]:
    """Run every drive; write the summary and aggregate into ``out_dir``; return the results
    in the order of ``drives`` (a path given twice runs once)."""
    from sideslip.vehicle import load_vehicle

    out = storage.normalise(out_dir)
    check_out_dir(out)
    veh = load_vehicle(vehicle)
    vehicle_ref = vehicle if not os.path.exists(vehicle) else storage.normalise(vehicle)
    paths = [storage.normalise(d) for d in drives]
    keys = output_keys(paths)
    storage.makedirs(out)
    chosen = tuple(methods) if methods else None
    extra = dict(settings or {})
    specs = [JobSpec(d, k, veh, vehicle_ref, out, chosen, extra, resume) for d, k in keys.items()]
    results: dict[str, JobResult] = {}
    for res in _results(specs, max(1, workers or 1), use_dask, scheduler, connect_timeout_s):
        results[res.key] = res
        if progress:
            progress(res)
    ordered = [results[s.key] for s in specs]
    write_summary(out, ordered, methods)
    return ordered


def write_summary(out: str, results: Sequence[JobResult], methods: Sequence[str] | None) -> None:
    """``summary.csv``, ``summary.json`` and ``aggregate.parquet`` in ``out`` (atomically)."""
    from sideslip.methods.registry import all_methods

    frame = summary_frame(results)
    storage.write_atomic(
        storage.join(out, "summary.csv"), lambda tmp: frame.to_csv(tmp, index=False, float_format="%.6g")
    )
    payload = [
        {
            "drive": r.drive, "output": r.output, "status": r.status, "rows": r.rows,
            "seconds": r.seconds, "methods": list(r.methods), "skipped": r.skipped,
            "metrics": r.metrics, "error": r.error,
        }
        for r in results
    ]  # fmt: skip
    storage.write_text(storage.join(out, "summary.json"), json.dumps(payload, indent=2))
    names = list(methods) if methods else [m for m in all_methods() if any(m in r.methods for r in results)]
    agg = aggregate_frame(results, names)
    storage.write_atomic(storage.join(out, "aggregate.parquet"), lambda tmp: agg.to_parquet(tmp, index=False))
