"""`sideslip methods` and `sideslip scenarios`: what the toolkit offers."""

from __future__ import annotations

import dataclasses
import json
from typing import Annotated, Any

import typer
from rich import box
from rich.table import Table

from sideslip.cli.app import app, console, guarded, write_output


def method_info(m: Any) -> dict[str, Any]:
    """A registered method as JSON-ready data: columns, vehicle parameters, paper, settings."""
    settings: dict[str, Any] = {}
    if m.settings is not None:
        defaults = m.default_settings()
        for f in dataclasses.fields(m.settings):
            settings[f.name] = getattr(defaults, f.name)
    return {
        "name": m.name,
        "columns": [c if isinstance(c, str) else list(c) for c in m.columns],
        "vehicle_params": list(m.vehicle_params),
        "paper": m.paper,
        "summary": m.summary,
        "settings": settings,
    }


@app.command("methods")
@guarded
def methods_cmd(
    as_json: Annotated[
        bool, typer.Option("--json", help="Print JSON: columns, vehicle parameters, settings.")
    ] = False,
    long: Annotated[bool, typer.Option("-l", "--long", help="Also say what each method does.")] = False,
) -> None:
    """List the registered methods, the columns each needs, and its paper."""
    from sideslip.drive import SPEED_COLUMNS
    from sideslip.methods.registry import all_methods

    registry = all_methods()
    if as_json:
        data = [method_info(m) for m in registry.values()]
        write_output("-", json.dumps(data, indent=2, default=str) + "\n")
        return
    table = Table(
        title="sideslip methods", box=box.SIMPLE_HEAD, pad_edge=False, title_justify="left",
        caption="speed: a wheel speed or v_can; a|b: either column.  What each does: --long; "
        "vehicle parameters and settings: --json",
        caption_justify="left",
    )  # fmt: skip
    table.add_column("method", no_wrap=True)
    table.add_column("paper", overflow="fold", max_width=16 if long else 26)
    table.add_column("needs columns", overflow="fold")
    if long:
        table.add_column("what it does", overflow="fold", ratio=2)
    for m in registry.values():
        needs = m.columns_text().replace("|".join(SPEED_COLUMNS), "speed")
        table.add_row(m.name, m.paper, needs, *([m.summary] if long else []))
    console.print(table)


@app.command("scenarios")
@guarded
def scenarios_cmd(
    as_json: Annotated[bool, typer.Option("--json", help="Print JSON: name -> description.")] = False,
) -> None:
    """List the simulator's named scenarios."""
    import sideslip.simulate as sim

    if as_json:
        data = {name: sim.describe(name) for name in sim.scenario_names()}
        write_output("-", json.dumps(data, indent=2) + "\n")
        return
    table = Table(title="sideslip scenarios", box=box.SIMPLE_HEAD, pad_edge=False, title_justify="left")
    table.add_column("scenario", no_wrap=True)
    table.add_column("description", overflow="fold")
    for name in sim.scenario_names():
        table.add_row(name, sim.describe(name))
    console.print(table)
