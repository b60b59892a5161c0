"""The gyro zero from the steering (``sideslip.calibrate.steer_yaw``) and what it gives
``fused`` without GNSS (``FusedSettings.steer_gyro_prior``, the smoother's gyro-bias prior).

Run: .venv/bin/python benchmarks/gyro_zero_steer.py
Writes benchmarks/results/gyro_zero_steer.md.

(a) The zero against the truth on pieces that start anywhere: every comparison scenario, seeds
    0-1, whole and cut into 20 s and 60 s pieces (half-overlapping); the shared real drives
    (Revs lap in 30 s pieces, comma2k19 minute in 20 s pieces) where ../shared/data is present.
    Truth: the simulator's drawn yaw-gyro bias; on the real drives the mean of w_z minus the
    reference's yaw rate (comma: the pose's; Revs: its INS's, which reads the same gyro, so 0).
(b) ``fused`` without GNSS, the prior off -> on (on: the default, which takes the steering's
    zero where its 1-sigma is at most ``FusedSettings.steer_gyro_prior_max_sigma``): the
    scenarios whole (seed 0) and in 20 s pieces (beta RMSE deg on rows faster than 5 m/s, and
    the share inside 2 sigma), and the real drives.
"""

from __future__ import annotations

import time
from dataclasses import replace
from pathlib import Path

import numpy as np
from compare_methods import SCENARIOS, load_scenario, two_sigma_share
from real_clips import clip
from real_log_rates import DRIVES
from results_file import write_result

from sideslip.calibrate.steer_yaw import steer_gyro_zero
from sideslip.drive import Drive
from sideslip.evaluate import metrics
from sideslip.methods.registry import run_method
from sideslip.vehicle import Vehicle, load_vehicle

OUT = Path(__file__).parent / "results" / "gyro_zero_steer.md"
SIM_PIECES_S = (20.0, 60.0)
REAL_PIECE_S = {"revs_lap": 30.0, "comma_minute": 20.0}
MIN_MOVING_S = 10.0  # pieces with less driving above 5 m/s are not scored in (b)


def _no_gnss(drive: Drive) -> Drive:
    return replace(drive, data={k: v for k, v in drive.data.items() if not k.startswith("gnss")})


def _starts(drive: Drive, length_s: float) -> np.ndarray:
    return np.arange(0.0, float(drive.t[-1] - drive.t[0]) - length_s + 1e-9, length_s / 2.0)


def _zero_rows(label: str, pieces: list[Drive], vehicle: Vehicle, truth: float) -> str:
    err, sd = [], []
    for piece in pieces:
        zero = steer_gyro_zero(piece, vehicle)
        if zero.informed:
            err.append(zero.value - truth)
            sd.append(zero.sigma)
    if not err:
        return f"| {label} | {len(pieces)} | 0 | – | – | – | – |"
    e, s = np.abs(np.array(err)), np.array(sd)
    return (
        f"| {label} | {len(pieces)} | {e.size} | {np.mean(e < 2.0 * s):.3f} | {np.median(e):.4f} | "
        f"{np.median(s):.4f} | {np.max(e / s):.1f} |"
    )


def _real() -> list[tuple[str, Drive, Vehicle]]:
    from sideslip.io import convert

    out = []
    for name, (kind, folder, preset) in DRIVES.items():
        if folder.is_dir():
            out.append((name, _no_gnss(convert(kind, folder, None, None)), load_vehicle(preset)))
    return out


def _fused(drive: Drive, vehicle: Vehicle, prior: bool) -> tuple[float, float]:
    est = run_method("fused", drive, vehicle, {"steer_gyro_prior": prior})
    share = two_sigma_share(drive, est)
    return float(metrics(drive, est.series)["beta_rmse_deg"]), float("nan") if share is None else share


def _moving_s(drive: Drive) -> float:
    ref = np.asarray(drive["ref_vx"])
    rows = np.isfinite(ref)  # the reference may be slower than the table (comma2k19: 20 Hz)
    return float(np.sum(np.diff(drive.t[rows])[ref[rows][1:] > 5.0]))


def _section_a(real: list[tuple[str, Drive, Vehicle]]) -> list[str]:
    head = "| drive | pieces | informed | inside 2 sigma | median abs error (rad/s) | median sigma | max error / sigma |"
    rows = ["## (a) The zero against the truth", "", head, "|---|---:|---:|---:|---:|---:|---:|"]
    for name in SCENARIOS:
        for seed in (0, 1):
            drive, vehicle = load_scenario(name, seed)
            truth = float(drive.meta["truth_sensor"]["gyro_bias_mean"][2])
            rows.append(_zero_rows(f"{name} seed {seed}, whole", [drive], vehicle, truth))
            for length in SIM_PIECES_S:
                pieces = [clip(drive, float(s), length) for s in _starts(drive, length)]
                rows.append(_zero_rows(f"{name} seed {seed}, {length:.0f} s", pieces, vehicle, truth))
    for name, drive, vehicle in real:
        truth = float(np.nanmean(drive["wz"] - drive["ref_r"]))
        rows.append(_zero_rows(f"{name}, whole", [drive], vehicle, truth))
        length = REAL_PIECE_S[name]
        pieces = [clip(drive, float(s), length) for s in _starts(drive, length)]
        rows.append(_zero_rows(f"{name}, {length:.0f} s", pieces, vehicle, truth))
    return [*rows, ""]


def _section_b(real: list[tuple[str, Drive, Vehicle]]) -> list[str]:
    rows = [
        "## (b) fused without GNSS, the steering's prior off -> on",
        "",
        "| drive | pieces scored | beta RMSE whole (deg) | 2 sigma whole | pieces: mean beta RMSE | pieces better / worse by > 10 % | pieces below 90 % inside 2 sigma |",
        "|---|---:|---|---|---|---:|---|",
    ]
    drives = [(name, *load_scenario(name, 0)) for name in SCENARIOS]
    for name, drive, vehicle in [(n, _no_gnss(d), v) for n, d, v in drives] + real:
        whole = [_fused(drive, vehicle, p) for p in (False, True)]
        length = REAL_PIECE_S.get(name, 20.0)
        scores = []
        for s in _starts(drive, length):
            piece = clip(drive, float(s), length)
            if _moving_s(piece) >= MIN_MOVING_S:
                scores.append([_fused(piece, vehicle, p) for p in (False, True)])
        if scores:
            sc = np.array(scores)  # (pieces, off/on, rmse/share)
            off, on = sc[:, 0, 0], sc[:, 1, 0]
            better = int(np.sum(on < 0.9 * off - 0.005))
            worse = int(np.sum(on > 1.1 * off + 0.005))
            low = f"{int(np.sum(sc[:, 0, 1] < 0.9))} -> {int(np.sum(sc[:, 1, 1] < 0.9))}"
            pieces = f"{off.mean():.4f} -> {on.mean():.4f} | {better} / {worse} | {low}"
        else:
            pieces = "– | – | –"
        rows.append(
            f"| {name} | {len(scores)} | {whole[0][0]:.3f} -> {whole[1][0]:.3f} | "
            f"{whole[0][1]:.2f} -> {whole[1][1]:.2f} | {pieces} |"
        )
    return [*rows, ""]


def main() -> None:
    import sys
    t0 = time.perf_counter()
    real = _real()
    if "--b" in sys.argv:
        print("\n".join(_section_b(real)))
        return
    body = _section_a(real) + _section_b(real)
    intro = (__doc__ or "").split("\n\n", 1)[0].replace("\n", " ") + (
        "  (a): share of the informed pieces whose error is inside 2 of the zero's own 1-sigma."
        "  (b): pieces with at least 10 s above 5 m/s; better / worse counts moves beyond 10 % and"
        " 0.005 deg."
    )
    write_result(OUT, "The gyro zero from the steering", "benchmarks/gyro_zero_steer.py",
                 time.perf_counter() - t0, intro, body)  # fmt: skip


if __name__ == "__main__":
    main()
