"""The real drives with vehicle files as rough as users' are: every method against the reference.

The shared real recordings (seed 002's Revs lap, no GNSS, vehicle ``revs_250lm``; the
comma2k19 minute with 10 Hz GNSS, vehicle ``rav4``), each with its preset and with one
parameter set off the way a user's file is: both cornering stiffnesses halved (values per
tyre where the contract wants them per axle) or doubled, the front 1.5 x and the rear 0.7 x,
the mass 1.3 x, the CG moved forwards by a tenth of the wheelbase, the yaw inertia halved, the
CG height 1.5 x, the steering ratio 1.2 x.  Beta RMSE (deg, rows above 5 m/s) of every method
that runs on the drive's columns, the 2-sigma share in brackets where the method gives a
beta_std; the best in bold, shares under 0.90 marked.  Skipped when ../shared/data is absent.
Writes ``benchmarks/results/real_rough_files.md``.
Run: ``.venv/bin/python benchmarks/real_rough_files.py``.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator
from pathlib import Path

from compare_methods import REVS_LAP, two_sigma_share
from real_log_rates import COMMA_SEGMENT
from results_file import write_result

from sideslip.drive import Drive
from sideslip.evaluate import metrics
from sideslip.methods.registry import get_method, run_method, why_not
from sideslip.vehicle import Vehicle, load_vehicle

OUT = Path(__file__).parent / "results" / "real_rough_files.md"
DRIVES = {"revs_lap": ("revs", REVS_LAP, "revs_250lm"), "comma_minute": ("comma2k19", COMMA_SEGMENT, "rav4")}
METHODS = ("fused", "fused_filter", "fg_batch", "kf_linear", "obs_bicycle", "obs_modified_nocomp",
           "doppler_slip", "mkf", "kkf")  # fmt: skip
FILES: dict[str, Callable[[Vehicle], Vehicle]] = {
    "preset": lambda v: v,
    "stiffness x0.5": lambda v: v.with_changes(cf=0.5 * v.cf, cr=0.5 * v.cr),
    "stiffness x2": lambda v: v.with_changes(cf=2.0 * v.cf, cr=2.0 * v.cr),
    "front x1.5, rear x0.7": lambda v: v.with_changes(cf=1.5 * v.cf, cr=0.7 * v.cr),
    "mass x1.3": lambda v: v.with_changes(mass=1.3 * v.mass),
    "CG +0.1 L forwards": lambda v: v.with_changes(lf=v.lf - 0.1 * (v.lf + v.lr), lr=v.lr + 0.1 * (v.lf + v.lr)),
    "yaw inertia x0.5": lambda v: v.with_changes(yaw_inertia=0.5 * v.yaw_inertia),
    "CG height x1.5": lambda v: v.with_changes(cg_height=1.5 * v.cg_height),
    "steering ratio x1.2": lambda v: v.with_changes(steering_ratio=1.2 * v.steering_ratio),
}


def _cells(drive: Drive, vehicle: Vehicle) -> Iterator[tuple[float, float | None] | None]:
    for method in METHODS:
        if why_not(get_method(method), drive, vehicle) is not None:
            yield None
            continue
        est = run_method(method, drive, vehicle)
        yield metrics(drive, est.series)["beta_rmse_deg"], two_sigma_share(drive, est)


def _row(name: str, file: str, cells: list[tuple[float, float | None] | None]) -> str:
    best = min(c[0] for c in cells if c is not None)
    out = []
    for cell in cells:
        if cell is None:
            out.append("–")
            continue
        rmse, share = cell
        text = f"**{rmse:.3f}**" if rmse == best else f"{rmse:.3f}"
        if share is not None:
            text += f" ({share:.2f}{' !' if share < 0.90 else ''})"
        out.append(text)
    return f"| {name} | {file} | " + " | ".join(out) + " |"


def main() -> None:
    from sideslip.io import convert

    t0 = time.perf_counter()
    body = ["| drive | vehicle file | " + " | ".join(METHODS) + " |", "|---|---|" + "---:|" * len(METHODS)]
    for name, (kind, folder, preset) in DRIVES.items():
        if not folder.is_dir():
            body.append(f"| {name} | real data absent: {folder} |" + " |" * len(METHODS))
            continue
        drive = convert(kind, folder, None, None)
        base = load_vehicle(preset)
        for file, change in FILES.items():
            body.append(_row(name, file, list(_cells(drive, change(base)))))
            print(name, file, flush=True)
    body += ["", "Beta RMSE in degrees; the 2-sigma share in brackets (' !': under 0.90).", ""]
    intro = " ".join(" ".join(__doc__.split("\n\n")[1].split()).split("Writes")[0].split())
    write_result(OUT, "The real drives with rough vehicle files", "benchmarks/real_rough_files.py",
                 time.perf_counter() - t0, intro, body)  # fmt: skip


if __name__ == "__main__":
    main()
