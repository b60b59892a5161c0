"""`sideslip methods` and `sideslip scenarios`: what the toolkit offers."""

from __future__ import annotations

from rich.table import Table

from sideslip.cli.app import app, console, guarded


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
    import sideslip.simulate as sim

    table = Table(title="sideslip scenarios")
    table.add_column("scenario")
    table.add_column("description", overflow="fold")
    for name in sim.scenario_names():
        table.add_row(name, sim.describe(name))
    console.print(table)
