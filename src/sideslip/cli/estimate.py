"""`sideslip estimate`: run methods on a drive and write their estimates."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Annotated, Any

import typer

from sideslip.cli.app import app, guarded
from sideslip.drive import LONG_DRIVE_ROWS
from sideslip.errors import InputError


def settings_from_cli(config: Path | None, assignments: list[str] | None) -> dict[str, Any]:
    """Method -> settings object from ``--config FILE`` then ``--set M.FIELD=VALUE`` (which wins).

    Checked before any method runs: an unknown method, field or out-of-range value is one line.
    """
    from sideslip.methods.registry import resolve_settings
    from sideslip.settings import load_settings_file, parse_assignment

    merged: dict[str, dict[str, Any]] = {}
    if config is not None:
        for name, table in load_settings_file(config).items():
            merged.setdefault(name, {}).update(table)
        resolve_settings(merged, str(config))  # name the file in its own errors
    for text in assignments or []:
        name, field, value = parse_assignment(text)
        merged.setdefault(name, {})[field] = value
    return resolve_settings(merged, "--set" if assignments else str(config))


def run_estimates(
    drive: Any,
    vehicle: Any,
    names: list[str] | None,
    quiet: bool = False,
    settings: dict[str, Any] | None = None,
) -> Any:
    """Run the named methods (or all the drive allows), reporting skipped ones, with a progress
    bar; returns :class:`~sideslip.estimate.Estimates` (estimates and skipped reasons).

    ``settings``: method name -> settings object (see :func:`settings_from_cli`).
    """
    from sideslip.api import estimate
    from sideslip.cli.app import detail, note, progress_bar
    from sideslip.methods.registry import all_methods

    registry = all_methods()
    if names:
        unknown = [n for n in names if n not in registry]
        if unknown:
            raise InputError(
                "--method", f"unknown method '{unknown[0]}': expected one of {', '.join(registry)}"
            )
    if not names and not _has_yaw_rate(drive):
        # the contract's drive table requires wz for all methods; only seed 005's
        # ekf_wss_sas works without a gyro, and runs when named
        raise InputError(
            drive.path,
            "required column is missing or empty: expected the yaw-rate gyro in rad/s "
            "(every method but ekf_wss_sas needs it; --method ekf_wss_sas runs that one alone)",
            column="wz",
        )
    total = len(names) if names else len(registry)
    with progress_bar("methods", total) as advance:

        def tell(event: str, name: str, i: int, n: int, detail: str) -> None:
            if event == "start":
                advance(0, f"{name} ({i + 1}/{n})")
                return
            advance(1)
            if not quiet:
                note(f"skipped {name}: {detail}" if event == "skip" else f"ran {name} ({detail} s)")

        result = estimate(drive, vehicle, names or None, settings, progress=tell)
    for est in result:  # -v: what each method identified
        nums = [(k, v) for k, v in est.params.items() if type(v) in (int, float)]
        detail(f"{est.method}: " + (", ".join(f"{k}={v:.4g}" for k, v in nums) or "no scalar params"))
    if not len(result):
        missing = _missing_most(result.skipped)
        if missing is not None:
            raise InputError(
                drive.path,
                "no method can run on this drive: most lack this column, missing or empty "
                "(the skipped reasons above say what each needs)",
                column=missing,
            )
        raise InputError(drive.path, "no method can run on this drive (see the skipped reasons above)")
    return result


def _missing_most(skipped: Mapping[str, str]) -> str | None:
    """The drive column the most skipped methods name as missing (``"drive lacks 'a', 'b'"``;
    ties: the first in sorted order), or None where none lacks a drive column."""
    import re
    from collections import Counter

    counts: Counter[str] = Counter()
    for reason in skipped.values():
        if reason.startswith("drive lacks"):
            counts.update(set(re.findall(r"'([^']+)'", reason)))
    if not counts:
        return None
    top = max(counts.values())
    return sorted(c for c, k in counts.items() if k == top)[0]


def _has_yaw_rate(drive: Any) -> bool:
    """True where the drive holds a ``wz`` column with at least one finite sample."""
    import numpy as np

    return "wz" in drive and bool(np.isfinite(drive["wz"]).any())


def run_methods(
    drive: Any,
    vehicle: Any,
    names: list[str] | None,
    quiet: bool = False,
    settings: dict[str, Any] | None = None,
) -> list[Any]:
    """:func:`run_estimates` as a list of estimates (skipped reasons only reported)."""
    return list(run_estimates(drive, vehicle, names, quiet, settings))


@app.command("estimate")
@guarded
def estimate_cmd(
    drive_path: Annotated[Path, typer.Argument(metavar="DRIVE", help="Drive table, .parquet or .csv.")],
    vehicle: Annotated[str, typer.Option("--vehicle", help="Vehicle preset name or TOML path.")],
    out: Annotated[Path, typer.Option("--out", help="Estimate table, .parquet or .csv.")],
    method: Annotated[
        list[str] | None, typer.Option("--method", help="Method to run (repeatable; default all possible).")
    ] = None,
    set_: Annotated[
        list[str] | None,
        typer.Option("--set", help="A method setting, METHOD.FIELD=VALUE (repeatable; wins over --config)."),
    ] = None,
    config: Annotated[
        Path | None, typer.Option("--config", help="Settings TOML: one [method] table of FIELD = VALUE.")
    ] = None,
    heading_convention: Annotated[
        str,
        typer.Option(
            "--heading-convention",
            help="Also write M.heading_deg with north-cw-deg (from North, clockwise, degrees).",
        ),
    ] = "enu-ccw-rad",
    geodetic: Annotated[
        bool, typer.Option("--geodetic", help="Also write M.lat, M.lon (deg) from the drive's origin.")
    ] = False,
    compact: Annotated[
        bool | None,
        typer.Option(
            "--compact/--no-compact",
            help="Hold the sensor channels in single precision (default: for drives over "
            f"{LONG_DRIVE_ROWS:,} rows, so a day at 100 Hz fits a few GB).",
        ),
    ] = None,
) -> None:
    """Run estimation methods on a drive and write their estimates (+ .params.json)."""
    set_compact = compact
    from sideslip.drive import load_drive
    from sideslip.estimate import save_estimates
    from sideslip.outputs import check_outputs, estimate_outputs, output_group
    from sideslip.tables import meta_path, table_rows
    from sideslip.vehicle import load_vehicle

    if out.suffix.lower() not in (".csv", ".parquet", ".pq"):
        raise InputError(str(out), "expected an output path ending in .csv or .parquet")
    from sideslip.cli.app import note
    from sideslip.conventions import HEADING_CONVENTIONS, with_conventions

    if heading_convention not in HEADING_CONVENTIONS:
        raise InputError(
            "--heading-convention",
            f"'{heading_convention}': expected one of {', '.join(HEADING_CONVENTIONS)}",
        )
    check_outputs(estimate_outputs(out), [drive_path, meta_path(drive_path), vehicle, config])
    chosen_settings = settings_from_cli(config, set_)
    veh = load_vehicle(vehicle)
    if compact is None:
        rows = table_rows(drive_path)
        compact = rows is not None and rows > LONG_DRIVE_ROWS
    # The methods never read the ref_* truth columns: they are not even loaded.
    drive = load_drive(drive_path, compact=compact, reference=False)
    if not compact and len(drive) > LONG_DRIVE_ROWS and set_compact is None:
        drive = drive.compact()  # a long CSV (its length is known only once read)
        compact = True
    if geodetic:
        from sideslip.conventions import drive_origin

        drive_origin(drive)  # fails before any method runs
    result = run_estimates(drive, veh, method, settings=chosen_settings)
    estimates = with_conventions(drive, list(result), heading_convention, geodetic)  # type: ignore[arg-type]
    t, skipped = drive.t, result.skipped
    del drive, result  # memory: only the estimates are written
    meta: dict[str, Any] = {"drive": str(drive_path), "vehicle": vehicle}
    if compact:
        meta["inputs"] = "compact drive: sensor channels held in single precision"
        note("read the drive compact (sensor channels in single precision)")
    with output_group():  # the table and its .params.json appear together, or neither
        params = save_estimates(t, estimates, out, meta, skipped)
    note(f"wrote {out} ({len(estimates)} methods) and {params}")
