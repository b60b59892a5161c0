"""The `sideslip` command (contract section 4).  It only composes the library's pieces."""

from __future__ import annotations

import json
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Annotated, Any, TypeVar

import numpy as np
import typer
from rich.console import Console
from rich.table import Table

from sideslip.errors import InputError

app = typer.Typer(
    name="sideslip",
    help="Vehicle sideslip, roll/bank, heading, bias and trajectory estimation from GNSS, IMU and CAN.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)
console = Console()
err_console = Console(stderr=True)
_STATE = {"debug": False}
F = TypeVar("F", bound=Callable[..., Any])


class CommandUnavailable(Exception):
    """A command whose substance has not landed: says what is missing, exits non-zero."""


def say(line: str) -> None:
    """One plain line on stderr, never wrapped (errors must stay one line at any width)."""
    err_console.print(line, markup=False, highlight=False, soft_wrap=True)


def _fail(message: str, code: int = 2) -> None:
    say(f"error: {message}")
    raise typer.Exit(code)


def guarded(func: F) -> F:
    """Turn InputError into one line on stderr and exit 2 (traceback only with --debug)."""
    import functools

    @functools.wraps(func)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        try:
            return func(*args, **kwargs)
        except (InputError, CommandUnavailable) as exc:
            if _STATE["debug"]:
                raise
            _fail(str(exc), 2 if isinstance(exc, InputError) else 3)
        except KeyboardInterrupt:
            _fail("interrupted", 130)
        return None

    return wrapper  # type: ignore[return-value]


@app.callback()
def _main(
    debug: Annotated[bool, typer.Option("--debug", help="Show tracebacks on errors.")] = False,
) -> None:
    _STATE["debug"] = debug


# ------------------------------------------------------------------------------------------
@app.command("methods")
@guarded
def methods_cmd() -> None:
    """List the registered methods, the columns each needs, and its paper."""
    from sideslip.methods.registry import all_methods

    table = Table(title="sideslip methods")
    table.add_column("method", no_wrap=True)
    for col in ("needs columns", "vehicle parameters", "paper", "what it does"):
        table.add_column(col, overflow="fold")
    for m in all_methods().values():
        table.add_row(m.name, m.columns_text(), ", ".join(m.vehicle_params) or "-", m.paper, m.summary)
    console.print(table)


@app.command("scenarios")
@guarded
def scenarios_cmd() -> None:
    """List the simulator's named scenarios."""
    sim = _simulator()
    table = Table(title="sideslip scenarios")
    table.add_column("scenario")
    table.add_column("description", overflow="fold")
    for name in sim.scenario_names():
        table.add_row(name, sim.describe(name))
    console.print(table)


def _simulator() -> Any:
    try:
        import sideslip.simulate as sim
    except ImportError as exc:  # pragma: no cover - only while the simulator is missing
        raise CommandUnavailable(f"the simulator is not available in this build ({exc})") from None
    if not hasattr(sim, "simulate"):
        raise CommandUnavailable("the simulator is not available in this build yet")
    return sim


@app.command("simulate")
@guarded
def simulate_cmd(
    scenario: Annotated[str, typer.Argument(help="Scenario name (see `sideslip scenarios`).")],
    out: Annotated[Path, typer.Option("--out", help="Output drive, .parquet or .csv.")],
    seed: Annotated[int, typer.Option("--seed", help="Random seed.")] = 0,
    vehicle: Annotated[
        str | None, typer.Option("--vehicle", help="Vehicle preset or TOML (default: the scenario's).")
    ] = None,
) -> None:
    """Simulate a scenario and write a drive with reference columns."""
    from sideslip.drive import save_drive
    from sideslip.vehicle import load_vehicle

    sim = _simulator()
    veh = load_vehicle(vehicle) if vehicle else None
    start = time.perf_counter()
    drive = sim.simulate(scenario, seed=seed, vehicle=veh)
    save_drive(drive, out)
    console.print(
        f"wrote {out}: {len(drive)} rows, {drive.t[-1] - drive.t[0]:.1f} s, "
        f"scenario {scenario}, seed {seed} ({time.perf_counter() - start:.1f} s)"
    )


def run_methods(drive: Any, vehicle: Any, names: list[str] | None, quiet: bool = False) -> list[Any]:
    """Run the named methods (or all the drive allows), reporting skipped ones; returns estimates."""
    from sideslip.methods.registry import all_methods, run_method, why_not

    registry = all_methods()
    if names:
        unknown = [n for n in names if n not in registry]
        if unknown:
            raise InputError(
                "--method", f"unknown method '{unknown[0]}': expected one of {', '.join(registry)}"
            )
        chosen = [registry[n] for n in names]
    else:
        chosen = list(registry.values())
    estimates = []
    for m in chosen:
        reason = why_not(m, drive, vehicle)
        if reason is not None:
            if names:
                run_method(m, drive, vehicle)  # raises the precise one-line error
            if not quiet:
                say(f"skipped {m.name}: {reason}")
            continue
        start = time.perf_counter()
        est = run_method(m, drive, vehicle)
        if not quiet:
            say(f"ran {m.name} ({time.perf_counter() - start:.2f} s)")
        estimates.append(est)
    if not estimates:
        raise InputError(drive.path, "no method can run on this drive (see the skipped reasons above)")
    return estimates


@app.command("estimate")
@guarded
def estimate_cmd(
    drive_path: Annotated[Path, typer.Argument(metavar="DRIVE", help="Drive table, .parquet or .csv.")],
    vehicle: Annotated[str, typer.Option("--vehicle", help="Vehicle preset name or TOML path.")],
    out: Annotated[Path, typer.Option("--out", help="Estimate table, .parquet or .csv.")],
    method: Annotated[
        list[str] | None, typer.Option("--method", help="Method to run (repeatable; default all possible).")
    ] = None,
) -> None:
    """Run estimation methods on a drive and write their estimates (+ .params.json)."""
    from sideslip.drive import load_drive
    from sideslip.estimate import save_estimates
    from sideslip.vehicle import load_vehicle

    if out.suffix.lower() not in (".csv", ".parquet", ".pq"):
        raise InputError(str(out), "expected an output path ending in .csv or .parquet")
    veh = load_vehicle(vehicle)
    drive = load_drive(drive_path)
    estimates = run_methods(drive, veh, method)
    params = save_estimates(drive.t, estimates, out, {"drive": str(drive_path), "vehicle": vehicle})
    console.print(f"wrote {out} ({len(estimates)} methods) and {params}")


def _parse_windows(values: list[str] | None) -> list[Any]:
    from sideslip.evaluate import Window

    out = []
    for v in values or []:
        try:
            a, b = (float(x) for x in v.split(":"))
        except ValueError:
            raise InputError("--window", f"'{v}': expected T0:T1 in seconds, e.g. 120:150") from None
        if not b > a:
            raise InputError("--window", f"'{v}': expected T1 > T0")
        out.append(Window(a, b))
    return out


def _check_same_time_base(drive: Any, est: dict[str, Any], est_path: Path) -> None:
    t_est = est[""]["t"]
    if t_est.size != len(drive) or not np.allclose(t_est, drive.t, rtol=0, atol=1e-6):
        raise InputError(
            str(est_path),
            "expected the drive's time stamps (estimate made from another drive?)",
            column="t",
        )


TERMINAL_METRICS = (
    ("beta_rmse_deg", "β RMSE °"),
    ("beta_max_err_deg", "β max °"),
    ("roll_rmse_deg", "roll RMSE °"),
    ("yaw_rmse_deg", "yaw RMSE °"),
    ("pos_rmse_m", "pos RMSE m"),
    ("xtrack_100m_p95_m", "xtrack p95 m"),
)


def metrics_table(results: dict[str, dict[str, float]], title: str) -> Table:
    """A compact rich table of the headline metrics, methods sorted by beta RMSE.

    Every metric (the contract's and the extra ones) goes to the JSON and the report; the
    terminal shows the six that fit a normal terminal width.
    """
    cols = [(k, label) for k, label in TERMINAL_METRICS if any(k in r for r in results.values())]
    table = Table(title=title)
    table.add_column("method", no_wrap=True)
    for _, label in cols:
        table.add_column(label, justify="right", no_wrap=True)
    order = sorted(results, key=lambda m: results[m].get("beta_rmse_deg", float("inf")))
    best = {k: min((abs(r[k]) for r in results.values() if k in r), default=None) for k, _ in cols}
    for method in order:
        vals = results[method]
        cells = []
        for k, _ in cols:
            if k not in vals:
                cells.append("-")
            elif best[k] is not None and abs(vals[k]) == best[k] and len(results) > 1:
                cells.append(f"[bold green]{vals[k]:.3f}[/]")
            else:
                cells.append(f"{vals[k]:.3f}")
        table.add_row(method, *cells)
    return table


@app.command("evaluate")
@guarded
def evaluate_cmd(
    drive_path: Annotated[Path, typer.Argument(metavar="DRIVE", help="Drive with reference columns.")],
    est_path: Annotated[Path, typer.Argument(metavar="EST", help="Estimate table from `sideslip estimate`.")],
    json_out: Annotated[
        Path | None, typer.Option("--json", help="Write method -> metric -> value JSON.")
    ] = None,
    window: Annotated[
        list[str] | None,
        typer.Option("--window", help="T0:T1 window (s) for per-window position errors, repeatable."),
    ] = None,
) -> None:
    """Compare estimates to the drive's reference columns; print a metrics table."""
    from sideslip.drive import _atomic_write, load_drive
    from sideslip.estimate import load_estimates
    from sideslip.evaluate import evaluate_all

    windows = _parse_windows(window)
    drive = load_drive(drive_path)
    est = load_estimates(est_path)
    t_est = est[""]["t"]
    if t_est.size != len(drive) or not np.allclose(t_est, drive.t, rtol=0, atol=1e-6):
        raise InputError(
            str(est_path),
            "expected the drive's time stamps (estimate made from another drive?)",
            column="t",
        )
    if not any(c.startswith("ref_") for c in drive.columns()):
        raise InputError(
            str(drive_path), "expected reference columns (ref_beta, ref_e, ...) to evaluate against"
        )
    results = evaluate_all(drive, est, windows)
    console.print(metrics_table(results, f"metrics: {est_path.name} vs {drive_path.name}"))
    if json_out is not None:
        _atomic_write(json_out, lambda tmp: tmp.write_text(json.dumps(results, indent=2)))
        console.print(f"wrote {json_out}")


@app.command("report")
@guarded
def report_cmd(
    drive_path: Annotated[Path, typer.Argument(metavar="DRIVE")],
    est_path: Annotated[Path, typer.Argument(metavar="EST")],
    out: Annotated[Path, typer.Option("--out", help="Output HTML file.")],
) -> None:
    """Write a self-contained HTML report with plots."""
    try:
        from sideslip.report.html import write_report
    except ImportError:
        raise CommandUnavailable("the HTML report is not available in this build yet") from None
    from sideslip.drive import load_drive
    from sideslip.estimate import load_estimates, params_path

    if out.suffix.lower() not in (".html", ".htm"):
        raise InputError(str(out), "expected an output path ending in .html")
    drive = load_drive(drive_path)
    est = load_estimates(est_path)
    _check_same_time_base(drive, est, est_path)
    params = None
    pj = params_path(est_path)
    if pj.is_file():
        params = json.loads(pj.read_text())
    write_report(drive, est, out, params)
    console.print(f"wrote {out}")


@app.command("bench")
@guarded
def bench_cmd(
    hours: Annotated[float, typer.Option("--hours", help="Length of the benchmark drive, h.")] = 1.0,
    method: Annotated[list[str] | None, typer.Option("--method", help="Only these methods.")] = None,
) -> None:
    """Time every method on a simulated drive: samples/s, peak memory, peer-library ratio."""
    try:
        from sideslip.bench import run_bench
    except ImportError:
        raise CommandUnavailable("the benchmark runner is not available in this build yet") from None
    run_bench(hours=hours, methods=method, console=console)


@app.command("convert")
@guarded
def convert_cmd(
    fmt: Annotated[str, typer.Argument(metavar="FORMAT", help="Input format (see --help).")],
    src: Annotated[Path, typer.Argument(metavar="SRC", help="Recording: dataset folder or file.")],
    out: Annotated[Path, typer.Option("--out", help="Output drive, .parquet or .csv.")],
    map_path: Annotated[Path | None, typer.Option("--map", help="Channel map TOML (mdf4, csv).")] = None,
    vehicle: Annotated[str | None, typer.Option("--vehicle", help="Vehicle preset or TOML.")] = None,
) -> None:
    """Turn an outside recording into a drive.  Formats: comma2k19, mdf4, csv."""
    try:
        from sideslip.io import FORMATS, convert
    except ImportError:
        raise CommandUnavailable("format converters are not available in this build yet") from None
    from sideslip.drive import save_drive
    from sideslip.vehicle import load_vehicle

    if fmt not in FORMATS:
        raise InputError(fmt, f"unknown format: expected one of {', '.join(FORMATS)}")
    veh = load_vehicle(vehicle) if vehicle else None
    drive = convert(fmt, src, veh, map_path)
    save_drive(drive, out)
    console.print(f"wrote {out}: {len(drive)} rows, {drive.t[-1] - drive.t[0]:.1f} s")


@app.command("batch")
@guarded
def batch_cmd(
    drives: Annotated[list[Path], typer.Argument(metavar="DRIVE...", help="Drive tables (many).")],
    vehicle: Annotated[str, typer.Option("--vehicle", help="Vehicle preset name or TOML path.")],
    out_dir: Annotated[Path, typer.Option("--out-dir", help="Folder for estimates and summary.")],
    method: Annotated[
        list[str] | None, typer.Option("--method", help="Method to run (repeatable; default all possible).")
    ] = None,
    workers: Annotated[int, typer.Option("--workers", help="Worker processes (default: CPUs).")] = 0,
    use_dask: Annotated[
        bool, typer.Option("--dask", help="Run on a local Dask cluster (extra 'fleet').")
    ] = False,
) -> None:
    """Estimate (and evaluate) many drives in parallel; write a summary table.

    A drive that fails validation is listed with its one-line error; the others go on.  Exits 1
    when any drive failed.
    """
    import os

    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

    from sideslip.batch import run_batch
    from sideslip.methods.registry import all_methods
    from sideslip.vehicle import load_vehicle

    load_vehicle(vehicle)  # a bad vehicle file fails once, here, not in every worker
    registry = all_methods()
    for name in method or []:
        if name not in registry:
            raise InputError("--method", f"unknown method '{name}': expected one of {', '.join(registry)}")
    if use_dask:
        import importlib.util

        if importlib.util.find_spec("distributed") is None:
            raise InputError("--dask", "dask.distributed is not installed: pip install 'sideslip[fleet]'")
    n_workers = workers if workers > 0 else min(len(drives), os.cpu_count() or 1)
    start = time.perf_counter()
    failed: list[str] = []
    with Progress(
        TextColumn("[progress.description]{task.description}"), BarColumn(), MofNCompleteColumn(),
        TimeElapsedColumn(), console=err_console,
    ) as progress:  # fmt: skip
        task = progress.add_task("drives", total=len(drives))

        def tick(res: Any) -> None:
            if res.error:
                failed.append(res.error)
            progress.advance(task)

        results = run_batch([str(d) for d in drives], vehicle, out_dir, method, n_workers, use_dask, tick)
    rows = sum(r.rows for r in results)
    elapsed = time.perf_counter() - start
    console.print(
        f"{len(results) - len(failed)} of {len(results)} drives done, {rows:,} rows in "
        f"{elapsed:.1f} s ({rows / max(elapsed, 1e-9):,.0f} rows/s with {n_workers} workers); "
        f"summary: {out_dir / 'summary.csv'}"
    )
    for line in failed:
        say(f"error: {line}")
    if failed:
        raise typer.Exit(1)


@app.command("demo")
@guarded
def demo_cmd(
    scenario: Annotated[str, typer.Option("--scenario", help="Scenario to run.")] = "demo",
    out_dir: Annotated[Path, typer.Option("--out-dir", help="Where to write the files.")] = Path("out"),
    seed: Annotated[int, typer.Option("--seed")] = 0,
) -> None:
    """Simulate a built-in scenario, run every method, print metrics, write the report."""
    from sideslip.drive import _atomic_write, save_drive
    from sideslip.estimate import save_estimates
    from sideslip.evaluate import evaluate_all
    from sideslip.vehicle import load_vehicle

    sim = _simulator()
    start = time.perf_counter()
    drive = sim.simulate(scenario, seed=seed)
    vehicle = load_vehicle(drive.meta["vehicle"])
    out_dir.mkdir(parents=True, exist_ok=True)
    drive_path = out_dir / f"{scenario}.parquet"
    save_drive(drive, drive_path)
    console.print(f"simulated {scenario} ({drive.t[-1]:.0f} s, vehicle {vehicle.name}) -> {drive_path}")
    estimates = run_methods(drive, vehicle, None)
    est_path = out_dir / f"{scenario}_estimates.parquet"
    save_estimates(drive.t, estimates, est_path, {"drive": str(drive_path), "vehicle": vehicle.name})
    series = {e.method: dict(e.series) for e in estimates}
    results = evaluate_all(drive, series)
    console.print(metrics_table(results, f"metrics on scenario '{scenario}'"))
    _atomic_write(
        out_dir / f"{scenario}_metrics.json", lambda tmp: tmp.write_text(json.dumps(results, indent=2))
    )
    try:
        from sideslip.report.html import write_report
    except ImportError:
        console.print(f"estimates: {est_path}; metrics: {out_dir / (scenario + '_metrics.json')}")
    else:
        report = out_dir / f"{scenario}_report.html"
        write_report(
            drive, {"": {"t": drive.t}, **series}, report, {e.method: dict(e.params) for e in estimates}
        )
        console.print(f"report: {report}")
    console.print(f"done in {time.perf_counter() - start:.1f} s")


def main() -> None:
    """Console entry point."""
    try:
        app()
    except SystemExit:
        raise
    except Exception as exc:
        if _STATE["debug"] or "--debug" in sys.argv:
            raise
        say(f"error: internal error {type(exc).__name__}: {exc} (re-run with --debug for a traceback)")
        sys.exit(1)


if __name__ == "__main__":
    main()
