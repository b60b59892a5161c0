"""The simulated drives cut into 20 s clips: short recordings with no standstill to start from.

The companion of ``real_clips.py`` on the 16 scenarios of the comparison (seed 0, right vehicle
file): each drive cut into 20 s clips starting every 10 s, with its own GNSS receiver (Doppler)
and with the GNSS columns removed, every clip run as a drive of its own by ``fused``,
``fused_filter`` and ``fg_batch`` (the paper method that runs on every column set).  Only
clips with at least 10 s faster than 5 m/s count.  Per receiver: the mean beta RMSE over the
clips, how many clips ``fused`` is more than 10 % behind ``fg_batch`` on (by scenario), the
clips with less than 90 % of the errors inside 2 beta_std, and the clips where ``fused`` is
furthest behind.  Writes ``benchmarks/results/sim_clips.md``.
Run: ``.venv/bin/python benchmarks/sim_clips.py``.
"""

from __future__ import annotations

import time
from collections import Counter
from pathlib import Path

import numpy as np
from compare_methods import SCENARIOS, load_scenario, two_sigma_share
from real_clips import clip
from results_file import write_result

from sideslip.drive import Drive, drive_from_columns
from sideslip.evaluate import SPEED_GATE, metrics
from sideslip.methods.registry import run_method

OUT = Path(__file__).parent / "results" / "sim_clips.md"
CLIP_S = 20.0
MIN_MOVING_S = 10.0
METHODS = ("fused", "fused_filter", "fg_batch")
SHARE_TARGET = 0.90


def without_gnss(drive: Drive) -> Drive:
    """``drive`` with its GNSS columns removed (IMU, wheel speeds and steering only)."""
    cols = {k: v for k, v in drive.data.items() if not k.startswith("gnss_")}
    return drive_from_columns({"t": drive.t, **cols}, dict(drive.meta))


def _clips(receiver: str) -> list[tuple[str, float, dict[str, tuple[float, float | None]]]]:
    """(scenario, clip start s, method -> (beta RMSE deg, 2-sigma share)) of every counted clip."""
    rows = []
    for name in SCENARIOS:
        drive, vehicle = load_scenario(name, 0)
        if receiver == "none":
            drive = without_gnss(drive)
        span = float(drive.t[-1] - drive.t[0])
        for start in np.arange(0.0, span - CLIP_S + 1e-9, CLIP_S / 2):
            piece = clip(drive, float(start), CLIP_S)
            moving_s = float(np.sum(piece["ref_vx"] > SPEED_GATE)) * float(np.median(np.diff(piece.t)))
            if moving_s < MIN_MOVING_S:
                continue
            scores = {}
            for m in METHODS:
                est = run_method(m, piece, vehicle)
                scores[m] = (float(metrics(piece, est.series)["beta_rmse_deg"]), two_sigma_share(piece, est))
            rows.append((name, float(start), scores))
        print(receiver, name, flush=True)
    return rows


def _section(title: str, rows: list[tuple[str, float, dict[str, tuple[float, float | None]]]]) -> list[str]:
    rmse = {m: np.array([s[m][0] for _, _, s in rows]) for m in METHODS}
    behind = [(n, st, s) for n, st, s in rows if s["fused"][0] > 1.1 * s["fg_batch"][0]]
    low = [
        f"{n} from {st:.0f} s: " + ", ".join(f"{m} {s[m][0]:.3f} ({s[m][1]:.2f})" for m in METHODS[:2])
        for n, st, s in rows
        if any(s[m][1] is not None and s[m][1] < SHARE_TARGET for m in METHODS)
    ]
    worst = sorted(rows, key=lambda r: r[2]["fused"][0] / max(r[2]["fg_batch"][0], 1e-9))[-5:]
    out = [
        f"## {title}: {len(rows)} clips",
        "",
        "| method | mean beta RMSE (deg) | lowest 2-sigma share |",
        "|---|---:|---:|",
    ]
    for m in METHODS:
        shares = [s[m][1] for _, _, s in rows if s[m][1] is not None]
        out.append(f"| {m} | {rmse[m].mean():.4f} | {min(shares):.2f} |")
    by_scenario = ", ".join(f"{k} {v}" for k, v in Counter(n for n, _, _ in behind).most_common())
    out += [
        "",
        f"`fused` more than 10 % behind `fg_batch` on {len(behind)} of {len(rows)} clips ({by_scenario}).",
        "",
        "Clips below 0.90 inside 2 sigma: " + ("; ".join(low) if low else "none") + ".",
        "",
        "Furthest behind (fused / fg_batch): "
        + "; ".join(f"{n} from {st:.0f} s {s['fused'][0]:.3f} / {s['fg_batch'][0]:.3f}" for n, st, s in reversed(worst))
        + ".",
        "",
    ]
    return out


def main() -> None:
    t0 = time.perf_counter()
    body = _section("Doppler (each scenario's own receiver)", _clips("doppler"))
    body += _section("no GNSS (IMU, wheel speeds, steering)", _clips("none"))
    intro = " ".join(__doc__.split("\n\n")[1].split("Writes")[0].split())
    write_result(OUT, "The simulated drives cut into 20 s clips", "benchmarks/sim_clips.py",
                 time.perf_counter() - t0, intro, body)  # fmt: skip


if __name__ == "__main__":
    main()
