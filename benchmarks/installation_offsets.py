"""Sensors the vehicle file misplaces: the antenna, the IMU, or a box that carries both.

Every simulated scenario of the comparison (seed 0, its own receiver with Doppler) with the
installation off the file's along x: the antenna 0.5 m ahead / behind
(``gnss_lever_offset_x``; all 16 scenarios), the IMU 1 m ahead / behind, or both together 1 m
ahead / behind (the IMU moved in the simulated car; the 11 own scenarios, as the CommonRoad
model takes no IMU place), and everything where the file says.  Three vehicle files each
(``compare_methods.FILES``).  ``fused`` with its installation checks (the default: the
antenna's tyre-free check, ``check_imu_lever``, ``check_box_lever``, and the tyres' profile of
a Doppler latency the tyre-free fits leave open, ``profile_doppler_latency``, which competes
with the installations, and where the drive has no slow turns the tyres' profile of the box,
``profile_box_lever``) against the same with the IMU, box and latency checks off
(``check_doppler_lever`` kept: the antenna's rule as before).  Per grid: the cells where a
check moved the IMU or the box or took a latency, those where the box's profile kept the
file's place and carried its doubt, the mean beta RMSE (deg, rows faster than 5 m/s) without
and with the checks, the lowest 2-sigma share, and the cell made worst.
Writes ``benchmarks/results/installation_offsets.md``.
Run: ``.venv/bin/python benchmarks/installation_offsets.py``.
"""

from __future__ import annotations

import dataclasses
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

from compare_methods import FILES, SCENARIOS, two_sigma_share
from results_file import write_result

from sideslip.evaluate import metrics
from sideslip.methods.fused import fuse
from sideslip.methods.fused_settings import FusedSettings
from sideslip.simulate import SensorConfig, simulate
from sideslip.simulate.run import _lookup  # the scenario's own sensor overrides
from sideslip.vehicle import load_vehicle

OUT = Path(__file__).parent / "results" / "installation_offsets.md"
OFF = FusedSettings(
    check_imu_lever=False, check_box_lever=False, profile_doppler_latency=False, profile_box_lever=False
)
# grid -> (what is off, offset m)
GRIDS = {
    "where the file says": ("antenna", 0.0),
    "antenna 0.5 m ahead": ("antenna", 0.5),
    "antenna 0.5 m behind": ("antenna", -0.5),
    "IMU 1 m ahead": ("imu", 1.0),
    "IMU 1 m behind": ("imu", -1.0),
    "box 1 m ahead": ("box", 1.0),
    "box 1 m behind": ("box", -1.0),
}


def _cell(task: tuple[str, str, float]) -> list[tuple[str, float, float, float, float, bool, str, bool]]:
    """One scenario of one grid, every vehicle file: (file, beta off, share off, beta on,
    share on, whether a check moved the IMU or the box or took a latency, which, whether the
    box's profile ran and kept the file's place)."""
    name, kind, offset = task
    cfg = SensorConfig().with_overrides(_lookup(name).sensor_overrides)
    if kind == "antenna":
        drive = simulate(name, seed=0, config=cfg.with_overrides({"gnss_lever_offset_x": offset}))
        right = load_vehicle(drive.meta["vehicle"])
    else:
        right = load_vehicle(simulate(name, seed=0).meta["vehicle"])
        x, y, z = right.imu_xyz
        truth = dataclasses.replace(right, imu_xyz=(x + offset, y, z))
        antenna = offset if kind == "box" else 0.0
        drive = simulate(name, seed=0, vehicle=truth, config=cfg.with_overrides({"gnss_lever_offset_x": antenna}))
    rows = []
    for key, (_, make) in FILES.items():
        vehicle = make(right)
        on = fuse(drive, vehicle, smooth=True)
        p = on.params
        late = "the tyre-free fits left it open" in str(p.get("gnss_doppler_latency_note", ""))
        moved = bool(p.get("imu_lever_x_applied_m") or p.get("box_x_applied_m") or late)
        profiled = "box_x_tyres_m" in p
        off = fuse(drive, vehicle, smooth=True, settings=OFF) if (moved or profiled) else on
        beta = [metrics(drive, e.series)["beta_rmse_deg"] for e in (off, on)]
        share = [two_sigma_share(drive, e) or 0.0 for e in (off, on)]
        what = ["IMU"] if p.get("imu_lever_x_applied_m") else []
        if p.get("box_x_applied_m"):
            by = "the tyres" if profiled else "the slow turns"
            what.append(f"box {float(p['box_x_applied_m']):+.2f} m by {by}")
        if late:
            what.append(f"Doppler {1000.0 * float(p['gnss_doppler_latency_s']):.0f} ms late")
        kept = profiled and not p.get("box_x_applied_m")
        rows.append((key, beta[0], share[0], beta[1], share[1], moved, ", ".join(what), kept))
    return rows


def main() -> None:
    start = time.perf_counter()
    tasks = []
    for grid, (kind, offset) in GRIDS.items():
        for name in SCENARIOS:
            if kind != "antenna" and name.startswith("cr_"):
                continue
            tasks.append((grid, (name, kind, offset)))
    with ProcessPoolExecutor(max_workers=2) as pool:
        results = list(pool.map(_cell, [t for _, t in tasks]))
    body = [
        "| installation against the file | cells | IMU or box moved, latency taken | box profiled, kept "
        "| mean beta without -> with the checks | lowest 2-sigma share without -> with | the cell made worst (deg) |",
        "|---|---:|---:|---:|---|---|---|",
    ]
    moved_lines = []
    for grid in GRIDS:
        cells = [
            (task[1][0], *row)
            for task, rows in zip(tasks, results, strict=True)
            if task[0] == grid
            for row in rows
        ]
        n = len(cells)
        moved = [c for c in cells if c[6]]
        mean_off = sum(c[2] for c in cells) / n
        mean_on = sum(c[4] for c in cells) / n
        worst = max(cells, key=lambda c: c[4] - c[2])
        worse = f"{worst[0]} {worst[1]} {worst[2]:.3f} -> {worst[4]:.3f}" if worst[4] > worst[2] else "none"
        body.append(
            f"| {grid} | {n} | {len(moved)} | {sum(1 for c in cells if c[8])} | {mean_off:.4f} -> {mean_on:.4f} "
            f"| {min(c[3] for c in cells):.2f} -> {min(c[5] for c in cells):.2f} | {worse} |"
        )
        moved_lines += [
            f"- {grid}, {c[0]}, {c[1]} file: {c[2]:.3f} ({c[3]:.2f}) -> {c[4]:.3f} ({c[5]:.2f}); {c[7]}"
            for c in moved
        ]
    body += ["", "Cells where a check moved the IMU or the box or took a latency (beta RMSE deg, 2-sigma share):",
             "", *moved_lines, ""]
    intro = __doc__.split("\n\n")[1].replace("\n", " ").split(" Writes ")[0]
    write_result(OUT, "Sensors the vehicle file misplaces", "benchmarks/installation_offsets.py",
                 time.perf_counter() - start, intro, body)  # fmt: skip


if __name__ == "__main__":
    main()
