"""The real drives logged at 100, 50, 20 and 10 Hz: what a slower logger does to the estimates.

The shared real recordings (seed 002's Revs lap, no GNSS; the comma2k19 minute with 10 Hz
GNSS), every row kept or every second / fifth / tenth row kept, as a logger that samples its
inputs without averaging them would record them: the car's vibration above the new Nyquist
rate folds into the band of the tyre forces (Revs: 0.85 m/s^2 per sample at 100 Hz).  The
comma minute's GNSS epochs move to the nearest kept row (at most half a row).  Beta RMSE
(deg, rows above 5 m/s) and the share of errors inside 2 beta_std for ``fused``,
``fused_filter`` and the paper methods that run on the columns, and ``fused`` with
``stiffness_bound_fallback`` off (where the learned rear stiffness falls below half the file's
through a noisy force, the smoother takes the file's stiffness, ``fused.fuse``; both columns
with the smoother's velocity random walk at least the accelerometer's white noise).  Skipped
when ../shared/data is absent.  Then the 100 Hz tables with the IMU alone at 50 / 20 / 10 Hz
(NaN between its samples).  Writes ``benchmarks/results/real_log_rates.md``.
Run: ``.venv/bin/python benchmarks/real_log_rates.py``.
"""

from __future__ import annotations

import time
from pathlib import Path
from typing import Any

import numpy as np
from compare_methods import REVS_LAP, two_sigma_share
from results_file import write_result

from sideslip.drive import Drive, drive_from_columns
from sideslip.evaluate import metrics
from sideslip.methods.registry import get_method, run_method, why_not
from sideslip.vehicle import load_vehicle

OUT = Path(__file__).parent / "results" / "real_log_rates.md"
COMMA_SEGMENT = REVS_LAP.parent / "comma2k19_example1" / "b0c9d2329ad1606b_2018-08-02--08-34-47_40"
DRIVES = {"revs_lap": ("revs", REVS_LAP, "revs_250lm"), "comma_minute": ("comma2k19", COMMA_SEGMENT, "rav4")}
STRIDES = {100: 1, 50: 2, 20: 5, 10: 10}  # table rate (Hz) -> every n-th row kept
METHODS = ("fused", "fused_filter", "fg_batch", "doppler_slip", "obs_bicycle", "kf_linear")
NO_FALLBACK = {"stiffness_bound_fallback": False}


def logged_at(drive: Drive, stride: int, phase: int = 0) -> Drive:
    """Every ``stride``-th row of ``drive`` from row ``phase``; each GNSS epoch on the kept row
    nearest to it."""
    if stride == 1:
        return drive
    keep = np.arange(phase, len(drive), stride)
    cols = {k: np.asarray(v)[keep].copy() for k, v in drive.data.items()}
    gnss = [k for k in cols if k.startswith("gnss_")]
    for k in gnss:
        cols[k][:] = np.nan
    if gnss:
        epochs = np.flatnonzero(np.isfinite(np.asarray(drive[gnss[0]], dtype=float)))
        rows = np.clip(np.round((epochs - phase) / stride).astype(int), 0, keep.size - 1)
        for k in gnss:
            cols[k][rows] = np.asarray(drive[k], dtype=float)[epochs]
    return drive_from_columns({"t": drive.t[keep], **cols}, dict(drive.meta))


def _cell(drive: Drive, vehicle: Any, method: str, settings: dict | None = None) -> str:
    if why_not(get_method(method), drive, vehicle) is not None:
        return "–"
    est = run_method(method, drive, vehicle, settings)
    rmse = metrics(drive, est.series)["beta_rmse_deg"]
    if method.startswith("fused"):
        return f"{rmse:.3f} ({two_sigma_share(drive, est):.2f})"
    return f"{rmse:.3f}"


def _rear_scale(drive: Drive, vehicle: Any) -> str:
    """``fused``'s learned rear stiffness scale, or what it asked for where the fallback took
    the file's."""
    params = run_method("fused", drive, vehicle).params
    note = str(params.get("rear_stiffness_scale_note", ""))
    if note.startswith("not learned"):
        return f"file's (asked {note.split('asked for ')[1].split(' x')[0]})"
    return f"{params['rear_stiffness_scale']:.3f}"


def _phases() -> list[str]:
    """The Revs lap at 20 Hz from each of the five row phases: which rows a logger keeps
    decides what the vibration folds to."""
    if not REVS_LAP.is_dir():
        return []
    from sideslip.io import convert

    whole = convert("revs", REVS_LAP, None, None)
    vehicle = load_vehicle("revs_250lm")
    out = [
        "## The Revs lap at 20 Hz from each row phase",
        "",
        "Every fifth row from row 0 (the table above) to row 4.  Which rows the logger keeps decides "
        "what the vibration folds to: the learned rear stiffness scale of `fused` (of the file's; "
        "where the fallback took the file's, what the drive asked for) and the beta RMSE (deg).",
        "",
        "| first row | fused | rear scale | fused, no fallback | fused_filter | fg_batch |",
        "|---:|---:|---:|---:|---:|---:|",
    ]
    for phase in range(5):
        drive = logged_at(whole, 5, phase)
        cells = [_cell(drive, vehicle, "fused"), _rear_scale(drive, vehicle),
                 _cell(drive, vehicle, "fused", NO_FALLBACK), _cell(drive, vehicle, "fused_filter"),
                 _cell(drive, vehicle, "fg_batch")]  # fmt: skip
        out.append(f"| {phase} | " + " | ".join(cells) + " |")
        print("revs 20 Hz phase", phase, flush=True)
    return [*out, ""]


IMU = ("ax", "ay", "az", "wx", "wy", "wz")


def imu_every(drive: Drive, stride: int) -> Drive:
    """``drive`` with its IMU's samples on every ``stride``-th row only (NaN between them): an
    IMU slower than the table the other sensors set, as the contract allows."""
    data = dict(drive.data)
    between = np.ones(len(drive), dtype=bool)
    between[::stride] = False
    for name in IMU:
        if name in data:
            col = np.asarray(data[name], dtype=float).copy()
            col[between] = np.nan
            data[name] = col
    return Drive(drive.t, data, drive.meta, drive.path)


def _slow_imu(header: list[str]) -> list[str]:
    """Both drives at 100 Hz with the IMU at 50 / 20 / 10 Hz inside the table."""
    from sideslip.io import convert

    out = [
        "## An IMU slower than the table",
        "",
        "The 100 Hz tables with the IMU's samples on every second / fifth / tenth row only (NaN "
        "between them; the speed, steering and GNSS as recorded): what a 50 / 20 / 10 Hz IMU "
        "beside a 100 Hz CAN bus gives.  The same IMU samples as the 50 / 20 / 10 Hz tables "
        "above.",
        "",
        "| " + " | ".join(["drive", "IMU rate", *header[2:]]) + " |",
        "|---|---|" + "---:|" * (len(header) - 2),
    ]
    for name, (kind, folder, preset) in DRIVES.items():
        if not folder.is_dir():
            continue
        whole = convert(kind, folder, None, None)
        vehicle = load_vehicle(preset)
        for rate, stride in list(STRIDES.items())[1:]:
            drive = imu_every(whole, stride)
            cells = [_cell(drive, vehicle, "fused"), _cell(drive, vehicle, "fused", NO_FALLBACK)]
            cells += [_cell(drive, vehicle, m) for m in METHODS[1:]]
            out.append(f"| {name} | {rate} Hz | " + " | ".join(cells) + " |")
            print(name, "imu", rate, flush=True)
    return [*out, ""]


def main() -> None:
    from sideslip.io import convert

    t0 = time.perf_counter()
    header = ["drive", "table rate", "fused", "fused, no fallback", *METHODS[1:]]
    body = ["| " + " | ".join(header) + " |", "|---|---|" + "---:|" * (len(header) - 2)]
    for name, (kind, folder, preset) in DRIVES.items():
        if not folder.is_dir():
            body.append(f"| {name} | – | real data absent: {folder} |" + " |" * (len(header) - 3))
            continue
        whole = convert(kind, folder, None, None)
        vehicle = load_vehicle(preset)
        for rate, stride in STRIDES.items():
            drive = logged_at(whole, stride)
            cells = [_cell(drive, vehicle, "fused"), _cell(drive, vehicle, "fused", NO_FALLBACK)]
            cells += [_cell(drive, vehicle, m) for m in METHODS[1:]]
            body.append(f"| {name} | {rate} Hz | " + " | ".join(cells) + " |")
            print(name, rate, flush=True)
    body += ["", "Beta RMSE in degrees; for fused and fused_filter the 2-sigma share in brackets.", ""]
    body += _phases()
    body += _slow_imu(header)
    intro = " ".join(__doc__.split("\n\n")[0].split()) + "  " + " ".join(
        " ".join(__doc__.split("\n\n")[1].split()).split("Writes")[0].split()
    )
    write_result(OUT, "The real drives logged at 100, 50, 20 and 10 Hz", "benchmarks/real_log_rates.py",
                 time.perf_counter() - t0, intro, body)  # fmt: skip


if __name__ == "__main__":
    main()
