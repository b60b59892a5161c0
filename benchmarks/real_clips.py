"""The real drives cut into clips that start anywhere: what a short recording gets.

Users bring clips: a minute cut from a longer log, a recording that starts at speed, in a
braking zone or in the middle of a corner, with no standstill to calibrate the gyro.  Each
shared real drive (seed 002's Revs lap, no GNSS; the comma2k19 minute, 10 Hz GNSS) is cut into
clips of a fixed length starting every half length, and every method the columns allow runs
on each clip as on a drive of its own.  Per method: the median and the worst beta RMSE over
the clips (deg, rows faster than 5 m/s), the worst 2-sigma share and how many clips keep
less than 0.90 inside 2 beta_std (methods that give beta_std), and how often the method is
the best of the clip.  The whole drive's RMSE beside them.  Skipped when ../shared/data is
absent.  Writes ``benchmarks/results/real_clips.md``.
Run: ``.venv/bin/python benchmarks/real_clips.py``.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
from compare_methods import two_sigma_share
from real_log_rates import DRIVES
from results_file import write_result

from sideslip.drive import Drive, drive_from_columns
from sideslip.evaluate import metrics
from sideslip.methods.registry import get_method, run_method, why_not
from sideslip.vehicle import load_vehicle

OUT = Path(__file__).parent / "results" / "real_clips.md"
CLIP_S = {"revs_lap": (30.0, 60.0), "comma_minute": (20.0,)}
METHODS = (
    "fused", "fused_filter", "fg_batch", "fg_lag", "kf_linear", "doppler_slip", "mkf",
    "obs_bicycle", "obs_modified", "obs_kinematic", "kkf",
)  # fmt: skip
SHARE_TARGET = 0.90


def clip(drive: Drive, start_s: float, length_s: float) -> Drive:
    """The rows of ``drive`` from ``start_s`` after its first row, ``length_s`` long."""
    rel = drive.t - drive.t[0]
    keep = (rel >= start_s) & (rel < start_s + length_s)
    cols = {k: np.asarray(v)[keep] for k, v in drive.data.items()}
    return drive_from_columns({"t": drive.t[keep], **cols}, dict(drive.meta))


def _score(drive: Drive, vehicle: object, method: str) -> tuple[float, float | None] | None:
    """(beta RMSE deg, 2-sigma share or None) of ``method`` on ``drive``; None where the
    columns do not allow the method."""
    if why_not(get_method(method), drive, vehicle) is not None:
        return None
    est = run_method(method, drive, vehicle)
    return float(metrics(drive, est.series)["beta_rmse_deg"]), two_sigma_share(drive, est)


def _table(name: str, whole: Drive, vehicle: object, length_s: float) -> list[str]:
    span = float(whole.t[-1] - whole.t[0])
    starts = np.arange(0.0, span - length_s + 1e-9, length_s / 2)
    full = {m: _score(whole, vehicle, m) for m in METHODS}
    methods = [m for m in METHODS if full[m] is not None]
    scores: dict[str, list[tuple[float, float | None]]] = {m: [] for m in methods}
    for s in starts:
        piece = clip(whole, float(s), length_s)
        for m in methods:
            got = _score(piece, vehicle, m)
            scores[m].append(got if got is not None else (np.nan, None))
    rmse = np.array([[r for r, _ in scores[m]] for m in methods])
    best = np.nanargmin(rmse, axis=0)
    out = [
        f"## {name}: {starts.size} clips of {length_s:.0f} s (every {length_s / 2:.0f} s)",
        "",
        "| method | whole drive | median of clips | worst clip | worst clip starts at (s) | best of the clip | "
        "lowest 2-sigma share | clips below 0.90 |",
        "|---|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for i, m in enumerate(methods):
        shares = [sh for _, sh in scores[m] if sh is not None]
        worst = int(np.nanargmax(rmse[i]))
        share_cells = (
            [f"{min(shares):.2f}", str(sum(sh < SHARE_TARGET for sh in shares))] if shares else ["–", "–"]
        )
        out.append(
            f"| {m} | {full[m][0]:.3f} | {np.nanmedian(rmse[i]):.3f} | {rmse[i, worst]:.3f} | "  # type: ignore[index]
            f"{starts[worst]:.0f} | {int(np.sum(best == i))} | " + " | ".join(share_cells) + " |"
        )
    return [*out, ""]


def main() -> None:
    from sideslip.io import convert

    t0 = time.perf_counter()
    body: list[str] = []
    for name, (kind, folder, preset) in DRIVES.items():
        if not folder.is_dir():
            body += [f"{name}: real data absent ({folder}).", ""]
            continue
        whole = convert(kind, folder, None, None)
        vehicle = load_vehicle(preset)
        for length_s in CLIP_S[name]:
            body += _table(name, whole, vehicle, length_s)
            print(name, length_s, flush=True)
    intro = " ".join(__doc__.split("\n\n")[1].split("Writes")[0].split())
    write_result(OUT, "The real drives cut into clips", "benchmarks/real_clips.py",
                 time.perf_counter() - t0, intro, body)  # fmt: skip


if __name__ == "__main__":
    main()
