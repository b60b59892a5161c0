"""Real-data check (issue 10, item 3): every registered method on the comma2k19 minute.

Runs each method the converted minute allows (``registry.why_not`` says why the others are
skipped) and reports, against comma's global pose (mount misalignment removed, see
``sideslip.io.comma2k19``):

* heading: RMSE and mean of wrap(yaw - ref_yaw) over the pose rows;
* gyro bias: the method's final ``gyro_bias`` against Android's bias estimate and against the
  pose-derived bias mean(wz - ref_r) (not independent: the pose used this IMU);
* wheel-speed scale factor, normalised to measured/true, against rear-wheel speed / pose speed;
* dead reckoning: position error with GNSS (whole minute) and at the end of a GNSS outage made
  by blanking every GNSS column after the first ``OUTAGE_START_S`` seconds; a baseline without
  any estimator (Android-bias-corrected gyro + raw CAN speed, started from the pose) for scale;
* sideslip: RMSE against the pose's and, for methods with ``beta_std``, the share of beta errors
  inside 2 beta_std (0.95 for a calibrated Gaussian).

Run: ``.venv/bin/python benchmarks/realdata_check.py [SEGMENT_DIR]``; writes
``benchmarks/results/realdata_check.md``.  The functions are reused by
``tests/io/test_realdata_check.py``.
"""

from __future__ import annotations

import datetime as dt
import math
import sys
import time
from collections.abc import Mapping
from dataclasses import fields
from pathlib import Path
from typing import Any

import numpy as np

from sideslip.drive import Drive
from sideslip.estimate import Estimate
from sideslip.evaluate import metrics
from sideslip.frames import wrap_angle
from sideslip.io.comma2k19 import convert_comma2k19
from sideslip.methods.registry import all_methods, run_method, why_not
from sideslip.vehicle import Vehicle, load_vehicle

ROOT = Path(__file__).resolve().parents[1]
SEGMENT = (ROOT.parent / "shared" / "data" / "comma2k19_example1"
           / "b0c9d2329ad1606b_2018-08-02--08-34-47_40")
RESULT = ROOT / "benchmarks" / "results" / "realdata_check.md"
OUTAGE_START_S = 20.0  # GNSS kept for the first 20 s, then a 40 s outage to the end
GNSS_COLUMNS = ("gnss_e", "gnss_n", "gnss_u", "gnss_ve", "gnss_vn", "gnss_vu",
                "gnss_pos_std", "gnss_vel_std")


def wheel_ratio(method: str, params: Mapping[str, Any]) -> float | None:
    """A method's identified wheel-speed scale factor as measured/true speed, None if absent.

    Conventions differ between families: doppler_slip* give SF = true/measured (seed 000
    eq 4), ekf_wss_sas* give measured = (1 + sf) true, fused* give measured = s_w true.
    """
    if "scale_factor_convention" in params and "(1 + scale_factor)" in str(
        params["scale_factor_convention"]
    ) and "wheel_scale_factor" in params:
        return 1.0 + float(params["wheel_scale_factor"])
    if method.startswith("doppler_slip") and "wheel_scale_factor" in params:
        sf = float(params["wheel_scale_factor"])
        return 1.0 / sf if sf > 0 else None
    if "wheel_speed_scale_factor" in params:
        return float(params["wheel_speed_scale_factor"])
    return None


def _ref_rows(drive: Drive) -> np.ndarray:
    return np.isfinite(drive["ref_yaw"]) & np.isfinite(drive["ref_e"])


def pose_facts(drive: Drive) -> dict[str, float]:
    """Reference figures from the pose: bias, rear-wheel ratio (measured/true)."""
    rows = _ref_rows(drive)
    t_ref = drive.t[rows]
    speed_ref = np.hypot(drive["ref_vx"][rows], drive["ref_vy"][rows])
    out: dict[str, float] = {}
    rear = []
    for name in ("v_rl", "v_rr"):
        ok = np.isfinite(drive[name])
        rear.append(np.interp(t_ref, drive.t[ok], drive[name][ok]))
    out["rear_wheel_ratio"] = float(np.mean(np.mean(rear, axis=0)) / np.mean(speed_ref))
    ok = np.isfinite(drive["v_can"])
    out["can_ratio"] = float(np.mean(np.interp(t_ref, drive.t[ok], drive["v_can"][ok]))
                             / np.mean(speed_ref))
    # pose-derived bias: mean of the raw gyro minus the pose yaw rate (both ISO, rad/s)
    out["pose_bias"] = float(np.mean(drive["wz"]) - np.mean(drive["ref_r"][rows]))
    out["android_bias"] = float(drive.meta["android_gyro_bias"][2])
    return out


def with_outage(drive: Drive, start_s: float = OUTAGE_START_S) -> Drive:
    """The drive with every GNSS column blanked after ``start_s`` from its first row."""
    cut = drive.t > drive.t[0] + start_s
    data = {k: (np.where(cut, np.nan, v) if k in GNSS_COLUMNS else v)
            for k, v in drive.data.items()}
    return Drive(drive.t, data, drive.meta, drive.path + f" (GNSS outage after {start_s:g} s)")


def baseline_dead_reckoning(drive: Drive, start_s: float = OUTAGE_START_S) -> float:
    """End-of-minute position error (m) of gyro + CAN speed dead reckoning from the pose.

    No estimator: yaw integrates wz minus Android's bias, speed is the raw CAN speed held,
    starting from the pose (position, yaw) at ``start_s``.  Gives the scale of the errors.
    """
    rows = _ref_rows(drive)
    k0 = int(np.flatnonzero(rows & (drive.t >= drive.t[0] + start_s))[0])
    k1 = int(np.flatnonzero(rows)[-1])
    t = drive.t[k0 : k1 + 1]
    wz = drive["wz"][k0 : k1 + 1] - drive.meta["android_gyro_bias"][2]
    ok = np.isfinite(drive["v_can"])
    v = np.interp(t, drive.t[ok], drive["v_can"][ok])
    dtt = np.diff(t)
    yaw = drive["ref_yaw"][k0] + np.r_[0.0, np.cumsum(wz[:-1] * dtt)]
    e = drive["ref_e"][k0] + np.r_[0.0, np.cumsum(v[:-1] * np.cos(yaw[:-1]) * dtt)]
    n = drive["ref_n"][k0] + np.r_[0.0, np.cumsum(v[:-1] * np.sin(yaw[:-1]) * dtt)]
    return float(np.hypot(e[-1] - drive["ref_e"][k1], n[-1] - drive["ref_n"][k1]))


def figures(drive: Drive, est: Estimate, facts: Mapping[str, float]) -> dict[str, Any]:
    """Heading, bias, scale factor and position figures of one estimate (see module doc)."""
    s = est.series
    rows = _ref_rows(drive)
    out: dict[str, Any] = {}
    if "yaw" in s:
        err = wrap_angle(s["yaw"][rows] - drive["ref_yaw"][rows])
        out["yaw_rmse_deg"] = float(np.degrees(np.sqrt(np.mean(err**2))))
        out["yaw_mean_err_deg"] = float(np.degrees(np.mean(err)))
    if "gyro_bias" in s:
        b = s["gyro_bias"]
        last = drive.t > drive.t[-1] - 10.0
        out["gyro_bias_final_degps"] = float(np.degrees(np.mean(b[last])))
        out["bias_minus_android_degps"] = float(np.degrees(np.mean(b[last]) - facts["android_bias"]))
        out["bias_minus_pose_degps"] = float(np.degrees(np.mean(b[last]) - facts["pose_bias"]))
    ratio = wheel_ratio(est.method, est.params)
    if ratio is not None:
        out["wheel_ratio"] = ratio
        out["wheel_ratio_minus_pose"] = ratio - facts["rear_wheel_ratio"]
    if "e" in s and "n" in s:
        err = np.hypot(s["e"][rows] - drive["ref_e"][rows], s["n"][rows] - drive["ref_n"][rows])
        out["pos_rmse_m"] = float(np.sqrt(np.mean(err**2)))
        out["pos_end_m"] = float(err[-1])
    m = metrics(drive, s)
    for key in ("beta_rmse_deg", "roll_rmse_deg", "r_rmse_degps"):
        if key in m:
            out[key] = m[key]
    share = beta_two_sigma_share(drive, est)
    if share is not None:
        out["beta_2sigma_share"] = share
    return out


def beta_two_sigma_share(drive: Drive, est: Estimate) -> float | None:
    """Share of the pose rows faster than 5 m/s whose beta error is inside 2 beta_std (0.95
    for a calibrated Gaussian), None without ``beta_std``."""
    if "beta_std" not in est.series or "beta" not in est.series:
        return None
    rows = np.isfinite(drive["ref_beta"]) & (drive["ref_vx"] > 5.0)
    if not rows.any():
        return None
    err = np.abs(wrap_angle(est["beta"][rows] - drive["ref_beta"][rows]))
    return float(np.mean(err < 2.0 * est["beta_std"][rows]))


def run_all(drive: Drive, vehicle: Vehicle) -> tuple[dict[str, dict[str, Any]], dict[str, str]]:
    """Every runnable method on ``drive``: name -> figures (+ runtime), and skipped -> reason."""
    facts = pose_facts(drive)
    results: dict[str, dict[str, Any]] = {}
    skipped: dict[str, str] = {}
    for name, method in all_methods().items():
        reason = why_not(method, drive, vehicle)
        if reason:
            skipped[name] = reason
            continue
        t0 = time.perf_counter()
        est = run_method(method, drive, vehicle)
        row = figures(drive, est, facts)
        row["runtime_s"] = time.perf_counter() - t0
        row["finite"] = all(bool(np.isfinite(v).all()) for v in est.series.values())
        row["series"] = sorted(est.series)
        results[name] = row
    return results, skipped


def outage_errors(drive: Drive, vehicle: Vehicle, names: list[str]) -> dict[str, dict[str, float]]:
    """End / max position error (m) over the GNSS outage for methods that output e, n."""
    cut = with_outage(drive)
    rows = _ref_rows(cut) & (cut.t > cut.t[0] + OUTAGE_START_S)
    methods = all_methods()
    out: dict[str, dict[str, float]] = {}
    for name in names:
        if why_not(methods[name], cut, vehicle):
            continue
        est = run_method(methods[name], cut, vehicle)
        err = np.hypot(est["e"][rows] - cut["ref_e"][rows], est["n"][rows] - cut["ref_n"][rows])
        out[name] = {"end_m": float(err[-1]), "max_m": float(err.max())}
    return out


def _fmt(value: Any, digits: int = 3) -> str:
    if value is None or (isinstance(value, float) and not math.isfinite(value)):
        return "-"
    if isinstance(value, float):
        return f"{value:.{digits}f}"
    return str(value)


def main(segment: Path = SEGMENT) -> str:
    vehicle = load_vehicle("rav4")
    drive = convert_comma2k19(segment, vehicle)
    facts = pose_facts(drive)
    results, skipped = run_all(drive, vehicle)
    with_pos = [n for n, r in results.items() if "pos_rmse_m" in r]
    outage = outage_errors(drive, vehicle, with_pos)
    base_dr = baseline_dead_reckoning(drive)
    lines = [
        "# Real-data check: comma2k19 minute (RAV4, I-280, 8-20 m/s)",
        "",
        f"Date: {dt.datetime.now(dt.UTC):%Y-%m-%d %H:%M} UTC.  Segment: `{segment.name}` "
        f"({len(drive)} IMU rows, {drive.t[-1] - drive.t[0]:.1f} s), vehicle preset `rav4`, "
        "raw gyro (`gyro_uncalibrated`).  Script: `benchmarks/realdata_check.py`.",
        "Reference: comma's global pose (INS/GNSS/vision fusion of the same IMU: not independent "
        "for the gyro bias) with the phone-mount misalignment removed "
        f"(mount yaw {drive.meta['mount']['yaw_deg']:.2f} deg, pitch "
        f"{drive.meta['mount']['pitch_deg']:.2f} deg, roll {drive.meta['mount']['roll_deg']:.2f} "
        "deg estimated on straight driving).",
        "",
        "## Pose facts",
        "",
        f"- rear-wheel speed / pose speed = {facts['rear_wheel_ratio']:.4f}; CAN speed / pose "
        f"speed = {facts['can_ratio']:.4f} (DATA_NOTES: 0.9916)",
        f"- yaw-rate gyro bias: Android {np.degrees(facts['android_bias']):.3f} deg/s, pose-derived "
        f"mean(wz - ref_r) {np.degrees(facts['pose_bias']):.3f} deg/s (ISO z up)",
        f"- sideslip excitation is tiny: |ref_beta| <= "
        f"{np.degrees(np.nanmax(np.abs(drive['ref_beta']))):.2f} deg; beta/roll figures below "
        "mostly measure noise and offsets, not slip tracking (an estimate of 0 scores "
        f"beta RMSE {np.degrees(np.sqrt(np.nanmean(drive['ref_beta'] ** 2))):.3f} deg)",
        "",
        "## Every runnable method",
        "",
        "yaw: heading error vs pose; bias: final gyro_bias (mean of the last 10 s) minus Android's / "
        "the pose-derived bias; wheel: identified wheel-speed scale factor as measured/true minus "
        "the pose ratio; pos: position error with GNSS over the minute (RMSE, at the end).",
        "",
        "| method | s | finite | yaw RMSE deg | yaw mean deg | bias deg/s | bias-Android | "
        "bias-pose | wheel ratio | wheel-pose | pos RMSE m | pos end m | beta RMSE deg | "
        "beta 2sigma share |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for name, r in results.items():
        lines.append(
            f"| {name} | {r['runtime_s']:.2f} | {r['finite']} | {_fmt(r.get('yaw_rmse_deg'))} | "
            f"{_fmt(r.get('yaw_mean_err_deg'))} | {_fmt(r.get('gyro_bias_final_degps'))} | "
            f"{_fmt(r.get('bias_minus_android_degps'))} | {_fmt(r.get('bias_minus_pose_degps'))} | "
            f"{_fmt(r.get('wheel_ratio'), 4)} | {_fmt(r.get('wheel_ratio_minus_pose'), 4)} | "
            f"{_fmt(r.get('pos_rmse_m'), 2)} | {_fmt(r.get('pos_end_m'), 2)} | "
            f"{_fmt(r.get('beta_rmse_deg'))} | {_fmt(r.get('beta_2sigma_share'), 2)} |"
        )
    lines += ["", "Skipped: " + ("; ".join(f"{k} ({v})" for k, v in skipped.items()) or "none"),
              "", f"## Dead reckoning through a GNSS outage ({OUTAGE_START_S:g} s to the end, "
              f"{drive.t[-1] - drive.t[0] - OUTAGE_START_S:.0f} s, ~"
              f"{np.nanmean(drive['v_can']) * (drive.t[-1] - drive.t[0] - OUTAGE_START_S):.0f} m)",
              "", "| method | error at end m | max error m |", "|---|---|---|"]
    for name, r in outage.items():
        lines.append(f"| {name} | {r['end_m']:.2f} | {r['max_m']:.2f} |")
    lines.append(f"| baseline: gyro - Android bias + raw CAN speed, started from the pose | "
                 f"{base_dr:.2f} | - |")
    cal = convert_comma2k19(segment, vehicle, gyro_calibrated=True)
    results_cal, _ = run_all(cal, vehicle)
    lines += ["", "## Same minute with Android's bias-corrected gyro (`gyro_calibrated=True`)", "",
              "Every method fed Android's bias-corrected gyro (the bias removed before the method).", "",
              "| method | yaw RMSE deg (raw -> calibrated) | beta RMSE deg (raw -> calibrated) |",
              "|---|---|---|"]
    for name, r in results_cal.items():
        raw = results.get(name, {})
        lines.append(f"| {name} | {_fmt(raw.get('yaw_rmse_deg'))} -> {_fmt(r.get('yaw_rmse_deg'))}"
                     f" | {_fmt(raw.get('beta_rmse_deg'))} -> {_fmt(r.get('beta_rmse_deg'))} |")
    lines += ["", "## The drive's own gyro zero on the raw gyro (`zero_gyro`)", "",
              "The methods with a `zero_gyro` setting (their papers assume a zeroed gyro, or their "
              "bias state starts from it) on the raw gyro, with the setting off (the samples as "
              "recorded, the bias state from 0) and on (the default: the bias of the drive's GNSS "
              "course windows and standstill, `sideslip.calibrate.sensors.drive_gyro_bias`).", "",
              "| method | yaw RMSE deg (off -> on) | beta RMSE deg (off -> on) |", "|---|---|---|"]
    for name, method in all_methods().items():
        if method.settings is None or "zero_gyro" not in {f.name for f in fields(method.settings)}:
            continue
        if why_not(method, drive, vehicle):
            continue
        off = figures(drive, run_method(method, drive, vehicle, {"zero_gyro": False}), facts)
        on = results.get(name, {})
        lines.append(f"| {name} | {_fmt(off.get('yaw_rmse_deg'))} -> {_fmt(on.get('yaw_rmse_deg'))}"
                     f" | {_fmt(off.get('beta_rmse_deg'))} -> {_fmt(on.get('beta_rmse_deg'))} |")
    lines.append("")
    text = "\n".join(lines)
    RESULT.parent.mkdir(parents=True, exist_ok=True)
    RESULT.write_text(text)
    return text


if __name__ == "__main__":
    print(main(Path(sys.argv[1]) if len(sys.argv) > 1 else SEGMENT))
