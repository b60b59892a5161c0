"""The `sideslip` command (contract section 4).  It only composes the library's pieces.

One module per command (or family of commands); each registers itself on the shared Typer
``app`` when imported here.
"""

from sideslip.cli import (
    batch,
    bench,
    calibrate,
    convert,
    demo,
    estimate,
    evaluate,
    info,
    report,
    simulate,
    vehicle,
)
from sideslip.cli.app import app, main

__all__ = [
    "app",
    "batch",
    "bench",
    "calibrate",
    "convert",
    "demo",
    "estimate",
    "evaluate",
    "info",
    "main",
    "report",
    "simulate",
    "vehicle",
]
