"""Writing a benchmark's result file: a title, the line that says when and by what it was
measured (with its run time), an introduction, then the body."""

from __future__ import annotations

import argparse
import datetime as dt
from collections.abc import Callable
from pathlib import Path


def write_result(out: Path, title: str, script: str, elapsed_s: float, intro: str, body: list[str]) -> None:
    """Write ``out`` as markdown: ``# title``, "Measured <UTC> by `script` (<elapsed> s)." and
    ``intro`` as one paragraph, then the ``body`` lines; print where it went."""
    stamp = dt.datetime.now(dt.UTC).strftime("%Y-%m-%d %H:%M UTC")
    head = [f"# {title}", "", f"Measured {stamp} by `{script}` ({elapsed_s:.0f} s).  {intro}", ""]
    out.write_text("\n".join(head + body))
    print(f"wrote {out}")


def scenario_main(doc: str, run: Callable[[tuple[str, ...]], str], scenarios: tuple[str, ...], out: Path) -> None:
    """The command line of a benchmark over scenarios: ``--scenario S`` (repeatable) runs
    only those and prints the table; without it every scenario runs and ``out`` is written."""
    parser = argparse.ArgumentParser(description=doc.split("\n\n")[0])
    parser.add_argument("--scenario", action="append", help="only these scenarios (printed, not written)")
    args = parser.parse_args()
    text = run(tuple(args.scenario) if args.scenario else scenarios)
    if args.scenario:
        print(text)
    else:
        out.write_text(text)
        print(f"wrote {out}")
