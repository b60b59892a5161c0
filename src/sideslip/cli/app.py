"""The Typer application and what every command shares: consoles, one-line errors, --debug."""

from __future__ import annotations

import functools
import sys
from collections.abc import Callable
from typing import Annotated, Any, TypeVar

import typer
from rich.console import Console

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


def say(line: str) -> None:
    """One plain line on stderr, never wrapped (errors must stay one line at any width)."""
    err_console.print(line, markup=False, highlight=False, soft_wrap=True)


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


@app.callback()
def _main(
    debug: Annotated[bool, typer.Option("--debug", help="Show tracebacks on errors.")] = False,
) -> None:
    _STATE["debug"] = debug


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
