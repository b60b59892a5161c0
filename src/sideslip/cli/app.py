"""The Typer application and what every command shares: consoles, one-line errors, global flags
(``--version``, ``-h``, ``-q``/``-v``, ``--debug``), output writing and progress bars."""

from __future__ import annotations

import contextlib
import functools
import sys
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Annotated, Any, TypeVar

import typer
from rich.console import Console

from sideslip.errors import InputError

app = typer.Typer(
    name="sideslip",
    help="Vehicle sideslip, roll/bank, heading, bias and trajectory estimation from GNSS, IMU and CAN.",
    no_args_is_help=True,
    add_completion=True,
    pretty_exceptions_enable=False,
    context_settings={"help_option_names": ["-h", "--help"]},
)
console = Console()
err_console = Console(stderr=True)
_STATE = {"debug": False, "quiet": False, "verbose": False}
F = TypeVar("F", bound=Callable[..., Any])


def say(line: str) -> None:
    """One plain line on stderr, never wrapped (errors must stay one line at any width)."""
    err_console.print(line, markup=False, highlight=False, soft_wrap=True)


def note(line: str) -> None:
    """A progress or status line on stderr; silenced by ``-q``."""
    if not _STATE["quiet"]:
        say(line)


def detail(line: str) -> None:
    """A diagnostic line on stderr, shown only with ``-v``."""
    if _STATE["verbose"] and not _STATE["quiet"]:
        say(line)


def quiet() -> bool:
    return bool(_STATE["quiet"])


def _fail(message: str, code: int = 2) -> None:
    say(f"error: {message}")
    raise typer.Exit(code)


def guarded(func: F) -> F:
    """Turn InputError into one line on stderr and exit 2 (traceback only with --debug)."""

    @functools.wraps(func)
    def wrapper(*args: Any, **kwargs: Any) -> Any:
        try:
            return func(*args, **kwargs)
        except InputError as exc:
            if _STATE["debug"]:
                raise
            _fail(str(exc), 2)
        except KeyboardInterrupt as exc:  # SIGINT, or SIGTERM/SIGHUP via outputs.Interrupted
            _fail("interrupted", 128 + getattr(exc, "signum", 2))
        return None

    return wrapper  # type: ignore[return-value]


# ------------------------------------------------------------------------------------------
# outputs: '-' is stdout; symlinks and devices are written through, regular files atomically
# ------------------------------------------------------------------------------------------
STDOUT_NAMES = ("-", "/dev/stdout", "/dev/fd/1", "/proc/self/fd/1")


def write_output(path: str | Path, data: str | bytes) -> str:
    """Write ``data`` to ``path`` and return where it went (for the "wrote ..." line).

    ``-`` (and ``/dev/stdout``) writes to this process's stdout; everything else goes through
    :func:`sideslip.outputs.atomic_write` (links written through, devices directly, regular
    files replaced atomically).
    """
    from sideslip.outputs import STDOUT, atomic_write

    raw = data.encode() if isinstance(data, str) else data
    if str(path) in STDOUT_NAMES:
        sys.stdout.flush()
        sys.stdout.buffer.write(raw)
        sys.stdout.buffer.flush()
        return "stdout"
    if Path(path).is_dir():
        raise InputError(str(path), "is a folder: expected a file name")
    atomic_write(path, lambda tmp: tmp.write_bytes(raw))
    return STDOUT if str(path) == STDOUT else str(path)


# ------------------------------------------------------------------------------------------
# progress: a bar on stderr when it is a terminal (and not -q)
# ------------------------------------------------------------------------------------------
@contextlib.contextmanager
def progress_bar(description: str, total: float | None) -> Iterator[Callable[..., None]]:
    """A rich progress bar on stderr; yields ``advance(steps=1, description=None)``.

    ``total=None`` shows a spinner with the elapsed time (steps of unknown length).  Off when
    stderr is not a terminal or with ``-q``, so logs and pipes get plain lines only.
    """
    from rich.progress import (
        BarColumn,
        MofNCompleteColumn,
        Progress,
        SpinnerColumn,
        TextColumn,
        TimeElapsedColumn,
    )

    columns = [SpinnerColumn(), TextColumn("{task.description}")]
    if total is not None:
        columns += [BarColumn(), MofNCompleteColumn()]
    columns.append(TimeElapsedColumn())
    disable = quiet() or not err_console.is_terminal
    with Progress(*columns, console=err_console, transient=True, disable=disable) as bar:
        task = bar.add_task(description, total=total)

        def advance(steps: float = 1, description: str | None = None) -> None:
            bar.update(task, advance=steps, description=description or bar.tasks[0].description)

        yield advance


# ------------------------------------------------------------------------------------------
# global options
# ------------------------------------------------------------------------------------------
def _version(value: bool) -> None:
    if value:
        from sideslip import __version__

        console.print(f"sideslip {__version__}", highlight=False)
        raise typer.Exit()


@app.callback()
def _main(
    debug: Annotated[bool, typer.Option("--debug", help="Show tracebacks on errors.")] = False,
    quiet_: Annotated[
        bool, typer.Option("-q", "--quiet", help="Only results and errors (no progress, no notes).")
    ] = False,
    verbose: Annotated[bool, typer.Option("-v", "--verbose", help="More detail on stderr.")] = False,
    version: Annotated[
        bool,
        typer.Option("--version", callback=_version, is_eager=True, help="Print the version and exit."),
    ] = False,
) -> None:
    _STATE["debug"] = debug
    _STATE["quiet"] = quiet_
    _STATE["verbose"] = verbose and not quiet_


def main() -> None:
    """Console entry point."""
    from sideslip.outputs import install_signal_handlers, remove_temps

    install_signal_handlers()
    try:
        app()
    except SystemExit:
        raise
    except KeyboardInterrupt as exc:
        say("error: interrupted")
        sys.exit(128 + getattr(exc, "signum", 2))
    except Exception as exc:
        if _STATE["debug"] or "--debug" in sys.argv:
            raise
        say(f"error: internal error {type(exc).__name__}: {exc} (re-run with --debug for a traceback)")
        sys.exit(1)
    finally:
        remove_temps()
