"""One drive of a batch: load, estimate, evaluate, write — idempotent, so it may run twice.

A job is a plain picklable :class:`JobSpec`; :func:`run_job` runs in a worker (a local process
or a Dask worker) and never raises for bad input: a drive that fails validation, or a method
that fails on it, comes back as a failed :class:`JobResult` with its one-line error.  Outputs
are keyed by the drive (:mod:`sideslip.batch.naming`) and written atomically, the manifest
last: a job re-run after a worker died rewrites the same files, never a second copy.
"""

from __future__ import annotations

import tempfile
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from sideslip.batch import manifest, storage
from sideslip.errors import InputError

STATUSES = ("run", "resumed", "failed")


@dataclass(frozen=True)
class JobSpec:
    """Everything a worker needs for one drive (paths absolute or fsspec URLs)."""

    drive: str
    key: str
    vehicle: Any  # a loaded sideslip.vehicle.Vehicle (workers need not read the file)
    vehicle_ref: str
    out_dir: str
    methods: tuple[str, ...] | None = None
    settings: dict[str, Any] = field(default_factory=dict)
    resume: bool = False


@dataclass(frozen=True)
class JobResult:
    """Outcome of one drive: metrics per method, or the error line that stopped it.

    ``status``: ``run`` (computed now), ``resumed`` (complete outputs found and verified),
    ``failed``.  ``skipped``: method -> why it could not run on this drive.
    """

    drive: str
    key: str = ""
    status: str = "run"
    rows: int = 0
    seconds: float = 0.0
    methods: tuple[str, ...] = ()
    skipped: dict[str, str] = field(default_factory=dict)
    metrics: dict[str, dict[str, float]] = field(default_factory=dict)
    error: str | None = None

    @property
    def output(self) -> str:
        return f"{self.key}_est.parquet" if self.key else ""


def _chosen(methods: tuple[str, ...] | None) -> list[Any]:
    from sideslip.methods.registry import all_methods

    registry = all_methods()
    return [registry[m] for m in methods] if methods else list(registry.values())


def _settings_record(spec: JobSpec) -> dict[str, dict[str, Any]]:
    """Method -> the settings it runs with (defaults unless the batch gave others)."""
    from sideslip.settings import settings_dict

    out: dict[str, dict[str, Any]] = {}
    for m in _chosen(spec.methods):
        chosen = spec.settings.get(m.name)
        out[m.name] = settings_dict(chosen if chosen is not None else m.default_settings())
    return out


def _result_dict(res: JobResult) -> dict[str, Any]:
    d = asdict(res)
    d["methods"] = list(res.methods)
    return d


def result_from_dict(d: dict[str, Any], status: str | None = None) -> JobResult:
    return JobResult(
        drive=str(d["drive"]), key=str(d.get("key", "")), status=status or str(d.get("status", "run")),
        rows=int(d.get("rows", 0)), seconds=float(d.get("seconds", 0.0)),
        methods=tuple(d.get("methods", ())), skipped=dict(d.get("skipped", {})),
        metrics=dict(d.get("metrics", {})), error=d.get("error"),
    )  # fmt: skip


def _estimate(spec: JobSpec, local_drive: Path, out_local: Path) -> JobResult:
    from sideslip.drive import load_drive
    from sideslip.estimate import save_estimates
    from sideslip.evaluate import evaluate_all
    from sideslip.methods.registry import check_method, run_method, why_not

    try:
        drive = load_drive(local_drive)
    except InputError as exc:  # a fetched copy: name the URL the user gave, not the copy
        if exc.file == str(local_drive):
            raise InputError(spec.drive, exc.expected, column=exc.column, row=exc.row) from None
        raise
    drive = type(drive)(drive.t, drive.data, drive.meta, spec.drive)  # messages name the input
    estimates = []
    skipped: dict[str, str] = {}
    runnable = []
    for m in _chosen(spec.methods):
        reason = why_not(m, drive, spec.vehicle)
        if reason is None:  # checked before any runs: a bad input costs no method's time
            runnable.append((m, check_method(m, drive, spec.vehicle, spec.settings.get(m.name))))
        else:
            skipped[m.name] = reason
    for m, resolved in runnable:
        estimates.append(run_method(m, drive, spec.vehicle, resolved, checked=True))
    if not estimates:
        raise InputError(
            spec.drive,
            "no method can run on this drive: " + "; ".join(f"{k}: {v}" for k, v in skipped.items()),
        )
    save_estimates(drive.t, estimates, out_local, {"drive": spec.drive, "vehicle": spec.vehicle_ref})
    has_ref = any(c.startswith("ref_") for c in drive.columns())
    results = evaluate_all(drive, {e.method: dict(e.series) for e in estimates}) if has_ref else {}
    return JobResult(
        spec.drive, spec.key, "run", len(drive), 0.0, tuple(e.method for e in estimates), skipped, results
    )


def _remove_stale_temps(stem: Path, before: float) -> None:
    """Delete temporary files of this drive's outputs (``.<name>_est.parquet.<random>.part``, ...)
    left by an earlier attempt that died mid-write (a worker killed by SIGKILL cannot clean
    up); only files older than this attempt's start, so a live concurrent attempt keeps its own."""
    folder, base = stem.parent, stem.name
    if not folder.is_dir():
        return
    for pattern in (f".{base}_*.part", f".{base}.*.part"):
        for tmp in folder.glob(pattern):
            try:
                if tmp.stat().st_mtime < before:
                    tmp.unlink()
            except OSError:
                pass


def run_job(spec: JobSpec) -> JobResult:
    """Estimate and evaluate one drive; write its outputs and manifest (never raises for bad
    input or a failing method: the result carries the error line)."""
    start = time.perf_counter()
    started_wall = time.time()
    try:
        fp = manifest.fingerprint(
            manifest.drive_sha256(spec.drive) if storage.exists(spec.drive) else "",
            manifest.vehicle_sha256(spec.vehicle),
            [m.name for m in _chosen(spec.methods)],
            _settings_record(spec),
        )
        if spec.resume and fp["drive_sha256"]:
            stored = manifest.complete(spec.out_dir, spec.key, fp)
            if stored is not None:
                return result_from_dict({**stored, "drive": spec.drive, "key": spec.key}, "resumed")
        with tempfile.TemporaryDirectory(prefix="sideslip-job-") as tmp:
            folder = Path(tmp)
            local_drive = storage.local_copy(spec.drive, folder) if storage.exists(spec.drive) else None
            if local_drive is None:
                raise InputError(spec.drive, "cannot read: no such file")
            target = storage.join(spec.out_dir, spec.key + "_est.parquet")
            if storage.is_url(target):
                out_local = folder / "out" / "est.parquet"
                res = _estimate(spec, local_drive, out_local)
                for suffix in manifest.OUTPUT_SUFFIXES:
                    local = folder / "out" / ("est" + suffix.removeprefix("_est"))
                    storage.upload(local, storage.join(spec.out_dir, spec.key + suffix))
            else:
                res = _estimate(spec, local_drive, Path(target))
        res = JobResult(**{**asdict(res), "seconds": time.perf_counter() - start})
        manifest.write(spec.out_dir, spec.key, fp, _result_dict(res))
        if not storage.is_url(spec.out_dir):
            _remove_stale_temps(Path(storage.join(spec.out_dir, spec.key)), started_wall)
        return res
    except InputError as exc:
        return JobResult(spec.drive, spec.key, "failed", seconds=time.perf_counter() - start, error=str(exc))
    except Exception as exc:  # a method's bug must not stop a fleet: report it on its drive
        line = str(exc).strip().splitlines()[0] if str(exc).strip() else ""
        return JobResult(
            spec.drive, spec.key, "failed", seconds=time.perf_counter() - start,
            error=f"{spec.drive}: internal error {type(exc).__name__}: {line}",
        )  # fmt: skip
