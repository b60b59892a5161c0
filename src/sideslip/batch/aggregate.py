"""A fleet at a glance: per method, the median and 95th percentile of every metric over the
drives, and the share of drives on which it ran, was resumed, could not run, or failed.

``aggregate_frame`` is the full table (written as ``aggregate.parquet``); ``console_lines``
is the 80-column view of it (β and roll RMSE) that ``sideslip batch`` prints.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
import pandas as pd

from sideslip.batch.job import JobResult

WIDTH = 80


def summary_frame(results: Sequence[JobResult]) -> pd.DataFrame:
    """One row per (drive, method) with its metrics; failed drives get one row with the error."""
    rows: list[dict[str, Any]] = []
    for r in results:
        base = {"drive": r.drive, "output": r.output, "status": r.status}
        if r.error is not None:
            rows.append({**base, "method": "", "error": r.error})
            continue
        for method in r.methods:
            rows.append(
                {**base, "method": method, "rows": r.rows, "seconds": r.seconds, **r.metrics.get(method, {})}
            )
    return pd.DataFrame(rows)


def aggregate_frame(results: Sequence[JobResult], methods: Sequence[str]) -> pd.DataFrame:
    """One row per method: drive counts and shares by outcome, ``<metric>_median`` and
    ``<metric>_p95`` over the drives that have the metric (NaN where none has it).

    Outcomes per (drive, method): ``run`` computed now, ``resumed`` taken from complete outputs,
    ``not_run`` the drive lacks what the method needs, ``failed`` the drive failed.
    """
    n = len(results)
    rows: list[dict[str, Any]] = []
    for method in methods:
        counts = dict.fromkeys(("run", "resumed", "not_run", "failed"), 0)
        values: dict[str, list[float]] = {}
        for r in results:
            if r.status == "failed":
                counts["failed"] += 1
            elif method in r.methods:
                counts["run" if r.status == "run" else "resumed"] += 1
                for metric, value in r.metrics.get(method, {}).items():
                    values.setdefault(metric, []).append(float(value))
            else:
                counts["not_run"] += 1
        row: dict[str, Any] = {"method": method, "drives": n}
        for k, c in counts.items():
            row[f"drives_{k}"] = c
            row[f"share_{k}"] = c / n if n else np.nan
        for metric in sorted(values):
            v = np.asarray(values[metric], dtype=float)
            v = v[np.isfinite(v)]
            row[f"{metric}_median"] = float(np.median(v)) if v.size else np.nan
            row[f"{metric}_p95"] = float(np.percentile(v, 95)) if v.size else np.nan
        rows.append(row)
    return pd.DataFrame(rows)


def _num(value: Any) -> str:
    if value is None or not np.isfinite(value):
        return "-"
    return f"{value:.3f}" if abs(value) < 10 else f"{value:.1f}"


def _pct(share: Any) -> str:
    return f"{100.0 * share:.0f}%" if share is not None and np.isfinite(share) else "-"


def console_lines(frame: pd.DataFrame) -> list[str]:
    """The aggregate as fixed-width lines of at most ``WIDTH`` characters."""
    head = (
        f"{'method':<22}{'run':>5}{'res':>5}{'n/a':>5}{'fail':>5}"
        f"{'beta RMSE deg':>16}{'':>2}{'roll RMSE deg':>16}"
    )
    sub = f"{'':<42}{'median':>8}{'p95':>8}{'':>2}{'median':>8}{'p95':>8}"
    lines = [head, sub]
    for _, r in frame.iterrows():
        lines.append(
            f"{str(r['method'])[:21]:<22}{_pct(r['share_run']):>5}{_pct(r['share_resumed']):>5}"
            f"{_pct(r['share_not_run']):>5}{_pct(r['share_failed']):>5}"
            f"{_num(r.get('beta_rmse_deg_median')):>8}{_num(r.get('beta_rmse_deg_p95')):>8}{'':>2}"
            f"{_num(r.get('roll_rmse_deg_median')):>8}{_num(r.get('roll_rmse_deg_p95')):>8}"
        )
    return [line.rstrip()[:WIDTH] for line in lines]
