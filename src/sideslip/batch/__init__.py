"""Fleet-scale runs: estimate (and evaluate, where there is a reference) over many drives.

Each drive is an independent, idempotent job (:mod:`sideslip.batch.job`): load and validate,
run the methods, write ``<out>/<key>_est.parquet`` (+ ``.params.json`` and a manifest), compute
metrics.  ``<key>`` is the drive's file stem, with parent folders where two drives share a stem
(:mod:`sideslip.batch.naming`).  Jobs run in this process, in worker processes, on a local
Dask cluster, or on a running Dask cluster (``scheduler=``) (:mod:`sideslip.batch.run`).  A
drive that fails is reported with its one-line error and the batch goes on; ``resume=True``
skips drives whose outputs are complete by content (:mod:`sideslip.batch.manifest`).  The
summary (``summary.csv``/``summary.json``, one row per drive and method) and the per-method
aggregate (``aggregate.parquet``, :mod:`sideslip.batch.aggregate`) are written at the end.
"""

from sideslip.batch.aggregate import aggregate_frame, console_lines, summary_frame
from sideslip.batch.job import JobResult, JobSpec, run_job
from sideslip.batch.naming import output_keys
from sideslip.batch.run import run_batch

__all__ = [
    "JobResult", "JobSpec", "aggregate_frame", "console_lines", "output_keys", "run_batch", "run_job",
    "summary_frame",
]  # fmt: skip
