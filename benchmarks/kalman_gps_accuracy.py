"""Seed 001 reproduction: kkf vs mkf vs mkf_adaptive, accuracy, Table I, speed vs FilterPy.

Run:  .venv/bin/python benchmarks/kalman_gps_accuracy.py [--quick]
Writes benchmarks/results/kalman_gps_accuracy.md.

* Process noise identified from the drive (issue 14): mkf / mkf_adaptive with the densities
  before issue 14, the paper preset and the default, on every simulated scenario of the method
  comparison, both vehicle files: beta RMSE, 2-sigma share, chosen factors, cost.
* Accuracy: beta RMSE / max error (deg, above the evaluation speed gate, from
  ``sideslip.evaluate.metrics``) of the three methods on the paper's two scenarios (several
  seeds; the right vehicle file and one with cornering stiffness 30 % low) and on other
  scenarios (seed 0), plus the residual diagnostics of the MKF.
* The paper's findings: KKF error at the end of each turn (gyro scale factor); bank-unaware vs
  bank-given MKF error in the 8 deg banked turn.
* Table I: steady-state 1-sigma from the discrete Riccati equation at 30 m/s, 5/20/50/100 Hz.
* Speed: samples per second of each method and of FilterPy's KalmanFilter running the same MKF
  on the same drive in this run (best of 3, after a warm-up run).
"""

from __future__ import annotations

import argparse
import datetime as dt
import platform
import time
from pathlib import Path

import numpy as np

from sideslip.drive import Drive
from sideslip.evaluate import metrics
from sideslip.methods import kalman_gps as kg
from sideslip.methods.kkf import Q_BIAS
from sideslip.simulate import simulate
from sideslip.vehicle import Vehicle, load_vehicle

ROOT = Path(__file__).resolve().parents[1]
OUT = ROOT / "benchmarks" / "results" / "kalman_gps_accuracy.md"
PAPER_SCENARIOS = ("two_turns_gyro_sf", "banked_track_turn")
OTHER_SCENARIOS = ("step_steer", "urban_course", "suburban_outages", "race_lap")
SEEDS = (0, 1, 2)
METHODS = {"kkf": kg.kkf, "mkf": kg.mkf, "mkf_adaptive": kg.mkf_adaptive}


def _row(drive: Drive, vehicle: Vehicle, name: str) -> dict[str, float]:
    est = METHODS[name](drive, vehicle)
    m = metrics(drive, est.series)
    out = {"rmse": m["beta_rmse_deg"], "max": m["beta_max_err_deg"]}
    res = est.params.get("residuals", {})
    out["verdict"] = "ok" if res.get("verdict") == "consistent" else ("mismatch" if "verdict" in res else "-")
    for ch in ("gyro", "course"):
        if ch in res:
            out[f"{ch}_colour"] = res[ch]["colour"]
            out[f"{ch}_nis"] = res[ch]["nis_mean"]
    return out


def accuracy(scenarios: tuple[str, ...], seeds: tuple[int, ...]) -> list[str]:
    lines = [
        "| scenario | seed | vehicle file | method | beta RMSE (deg) | beta max err (deg) "
        "| gyro resid. colour | gyro NIS | course resid. colour | course NIS | residual verdict |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for sc in scenarios:
        for seed in seeds:
            d = simulate(sc, seed=seed)
            veh = load_vehicle(d.meta["vehicle"])
            for label, v in (("right", veh), ("cf,cr -30 %", veh.with_changes(cf=0.7 * veh.cf, cr=0.7 * veh.cr))):
                for name in METHODS:
                    r = _row(d, v, name)
                    lines.append(
                        f"| {sc} | {seed} | {label} | {name} | {r['rmse']:.3f} | {r['max']:.3f} | "
                        f"{r.get('gyro_colour', float('nan')):.3f} | {r.get('gyro_nis', float('nan')):.3f} | "
                        f"{r.get('course_colour', float('nan')):.3f} | {r.get('course_nis', float('nan')):.3f} | {r['verdict']} |"
                    )
    return lines


def findings() -> list[str]:
    lines = []
    d = simulate("two_turns_gyro_sf", seed=0)
    veh = load_vehicle("blazer_suv")
    sf = d.meta["truth_sensor"]["gyro_scale_factor"]
    turning = np.abs(d["ref_r"]) > 0.1
    edges = np.flatnonzero(np.diff(turning.astype(int)))
    paper = kg.MkfSettings(preset="paper")
    errs = {"kkf": np.degrees(kg.kkf(d, veh)["beta"] - d["ref_beta"]),
            "mkf": np.degrees(kg.mkf(d, veh, paper)["beta"] - d["ref_beta"])}
    lines.append(f"two_turns_gyro_sf seed 0, gyro scale factor {sf:+.4f}:")
    lines.append("")
    lines.append("| turn | KKF mean abs err, first 1/5 (deg) | KKF last 1/5 (deg) | MKF max abs err in turn (deg) |")
    lines.append("|---|---|---|---|")
    for i, (a, b) in enumerate(zip(edges[::2], edges[1::2], strict=False)):
        n = b - a
        k = np.abs(errs["kkf"])
        lines.append(
            f"| {i + 1} | {k[a : a + n // 5].mean():.2f} | {k[b - n // 5 : b].mean():.2f} | "
            f"{np.abs(errs['mkf'][a:b]).max():.3f} |"
        )
    wrong = kg.mkf(d, load_vehicle("seed003_sedan"), paper)
    right = kg.mkf(d, veh, paper)
    lines.append("")
    lines.append(
        "Wrong vehicle file (seed003_sedan for the Blazer): MKF beta RMSE "
        f"{metrics(d, wrong.series)['beta_rmse_deg']:.3f} deg vs {metrics(d, right.series)['beta_rmse_deg']:.3f}; "
        f"gyro residual colour {wrong.params['residuals']['gyro']['colour']:.2f} vs "
        f"{right.params['residuals']['gyro']['colour']:.2f}, gyro NIS "
        f"{wrong.params['residuals']['gyro']['nis_mean']:.3f} vs {right.params['residuals']['gyro']['nis_mean']:.3f}."
    )
    b = simulate("banked_track_turn", seed=0)
    turning = np.abs(b["ref_r"]) > 0.1
    e0 = np.degrees(kg.run_mkf(b, veh, settings=paper)["beta"] - b["ref_beta"])[turning]
    e1 = np.degrees(kg.run_mkf(b, veh, bank=b["ref_bank"], settings=paper)["beta"]
                    - b["ref_beta"])[turning]
    e2 = np.degrees(kg.run_mkf(b, veh)["beta"] - b["ref_beta"])[turning]
    lines.append("")
    lines.append(
        f"banked_track_turn seed 0 (bank {np.degrees(b['ref_bank'][turning]).mean():.1f} deg in the turn): "
        f"bank-unaware MKF mean beta error in the turn {e0.mean():+.3f} deg; with the bank given "
        f"as known input {e1.mean():+.3f} deg (paper preset); the default (identified process "
        f"noise), bank-unaware: {e2.mean():+.3f} deg."
    )
    return lines


NOISE_SCENARIOS = ("step_steer", "slalom_low_mu", "banked_turn", "dlc_bank", "two_turns_gyro_sf",
                   "banked_track_turn", "urban_course", "urban_highway", "race_lap",
                   "suburban_outages", "demo", "cr_step_steer", "cr_slalom", "cr_circle")
# the MKF before issue 14's process-noise identification: typical densities given explicitly
# (so not tuned), gyro noise from the drive, no thrust-angle term
_TYP = kg.MkfNoise()
BEFORE = kg.MkfSettings(steer_psd_rad2_s=_TYP.steer_psd, beta_psd_rad2_per_s=_TYP.beta_psd,
                        yaw_accel_psd_rad2_s3=_TYP.yaw_accel_psd, thrust_angle_sigma_rad=0.0)
NOISE_SETTINGS = {"before": BEFORE, "paper": kg.MkfSettings(preset="paper"),
                  "auto": kg.MkfSettings()}


def _share(drive: Drive, est: object) -> float:
    fast = drive["ref_vx"] > 5.0
    err = np.abs(est["beta"] - drive["ref_beta"])[fast]  # type: ignore[index]
    return float(np.mean(err < 2.0 * est["beta_std"][fast]))  # type: ignore[index]


def noise_lines(scenarios: tuple[str, ...] = NOISE_SCENARIOS) -> list[str]:
    """mkf / mkf_adaptive with the process noise before issue 14, the paper preset and the
    drive-identified default: beta RMSE, 2-sigma share, the chosen factors, the tuning cost."""
    lines = [
        "| scenario | vehicle file | method | RMSE before | RMSE paper | RMSE auto | 2sigma before "
        "| 2sigma paper | 2sigma auto | auto steer/yaw factor | auto sideslip factor | auto / paper time |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    sums: dict[tuple[str, str, str], list[float]] = {}
    for sc in scenarios:
        d = simulate(sc, seed=0)
        veh = load_vehicle(d.meta["vehicle"])
        for label, v in (("right", veh), ("cf,cr -30 %", veh.with_changes(cf=0.7 * veh.cf, cr=0.7 * veh.cr))):
            for name in ("mkf", "mkf_adaptive"):
                fn = METHODS[name]
                rmse, share, cost = {}, {}, {}
                for key, st in NOISE_SETTINGS.items():
                    t0 = time.perf_counter()
                    est = fn(d, v, st)
                    cost[key] = time.perf_counter() - t0
                    rmse[key] = metrics(d, est.series)["beta_rmse_deg"]
                    share[key] = _share(d, est)
                    sums.setdefault((name, label, key), []).append(rmse[key])
                    if key == "auto":
                        ident = est.params["noise"]["process_noise_identification"]
                lines.append(
                    f"| {sc} | {label} | {name} | {rmse['before']:.3f} | {rmse['paper']:.3f} | "
                    f"{rmse['auto']:.3f} | {share['before']:.2f} | {share['paper']:.2f} | "
                    f"{share['auto']:.2f} | {ident['steer_yaw_factor']:g} | {ident['beta_factor']:g} | "
                    f"{cost['auto'] / cost['paper']:.1f} |"
                )
    lines += ["", "Mean beta RMSE over these scenarios (deg):", "",
              "| method | vehicle file | before | paper | auto |", "|---|---|---|---|---|"]
    for name in ("mkf", "mkf_adaptive"):
        for label in ("right", "cf,cr -30 %"):
            m = {k: float(np.mean(sums[(name, label, k)])) for k in NOISE_SETTINGS}
            lines.append(f"| {name} | {label} | {m['before']:.3f} | {m['paper']:.3f} | {m['auto']:.3f} |")
    return lines


KKF_BIAS_FACTORS = (0.1, 1.0, 10.0, 100.0, 1000.0)


def kkf_bias_lines(scenarios: tuple[str, ...] = NOISE_SCENARIOS) -> list[str]:
    """The KKF's one process density (gyro-bias walk) scored by its course-innovation
    likelihood on each drive, against the beta RMSE it gives: would the likelihood pick it?"""
    from sideslip.methods.mkf_tuning import neg2_log_likelihood

    head = " | ".join(f"-2lnL / RMSE x{f:g}" for f in KKF_BIAS_FACTORS)
    lines = [f"| scenario | {head} | RMSE at ML pick | RMSE fixed (x1) |",
             "|---|" + "---|" * (len(KKF_BIAS_FACTORS) + 2)]
    picked, fixed = [], []
    for sc in scenarios:
        d = simulate(sc, seed=0)
        veh = load_vehicle(d.meta["vehicle"])
        cells, scores, rmses = [], [], []
        for f in KKF_BIAS_FACTORS:
            st = kg.KkfSettings(gyro_bias_psd_rad2_s3=f * Q_BIAS)
            res = kg.run_kkf(d, veh, settings=st)
            score, _ = neg2_log_likelihood(res.innov, res.S)
            rmse = metrics(d, kg.kkf(d, veh, st).series)["beta_rmse_deg"]
            scores.append(score)
            rmses.append(rmse)
            cells.append(f"{score:.0f} / {rmse:.3f}")
        best = rmses[int(np.argmin(scores))]
        picked.append(best)
        fixed.append(rmses[KKF_BIAS_FACTORS.index(1.0)])
        lines.append(f"| {sc} | {' | '.join(cells)} | {best:.3f} | {fixed[-1]:.3f} |")
    lines += ["", f"Mean beta RMSE: at the likelihood's pick {np.mean(picked):.3f} deg, fixed "
              f"typical density {np.mean(fixed):.3f} deg."]
    return lines


def table_one_lines() -> list[str]:
    veh = load_vehicle("blazer_suv")
    lines = [
        "| rate (Hz) | sigma gyro (deg/s) | sigma course (deg) | ours sigma_beta (deg) | ours sigma_r (deg/s) "
        "| ours sigma_psi (deg) | paper sigma_beta_hat | paper sigma_r_hat |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for r in kg.table_one(veh):
        p = kg.TABLE_I_PAPER[r["rate_hz"]]
        lines.append(
            f"| {r['rate_hz']:g} | {r['sigma_gyro_deg_s']:.4f} | {r['sigma_course_deg']:.4f} | "
            f"{r['sigma_beta_deg']:.4f} | {r['sigma_r_deg_s']:.4f} | {r['sigma_yaw_deg']:.4f} | {p[0]} | {p[1]} |"
        )
    return lines


def _best_of(fn, n: int = 3) -> float:  # type: ignore[no-untyped-def]
    fn()
    best = float("inf")
    for _ in range(n):
        t0 = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - t0)
    return best


def speed_lines(quick: bool) -> list[str]:
    d = simulate("suburban_outages", seed=0)
    veh = load_vehicle(d.meta["vehicle"])
    n = len(d)
    lines = [f"Drive: suburban_outages seed 0, {n} rows ({d.t[-1] - d.t[0]:.0f} s at 100 Hz).", ""]
    lines += ["| method | samples/s |", "|---|---|"]
    rates = {}
    for name, fn in METHODS.items():
        rates[name] = n / _best_of(lambda fn=fn: fn(d, veh))
        lines.append(f"| {name} | {rates[name]:,.0f} |")
    try:
        from sideslip.peers import filterpy_kf
    except ImportError:
        lines.append("| filterpy (peer) | not installed |")
        return lines
    peer = n / _best_of(lambda: filterpy_kf.run(d, veh), 1 if quick else 2)
    diff = np.max(np.abs(filterpy_kf.run(d, veh) - kg.mkf(d, veh)["beta"]))
    lines.append(f"| filterpy KalmanFilter, same MKF (peer) | {peer:,.0f} |")
    lines.append("")
    lines.append(f"mkf / filterpy speed ratio: {rates['mkf'] / peer:.1f}x; max |beta difference| {diff:.2e} rad.")
    return lines


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true", help="seed 0 only")
    args = ap.parse_args()
    seeds = (0,) if args.quick else SEEDS
    t0 = time.time()
    parts = [
        "# Seed 001 reproduction: KKF / MKF / adaptive MKF",
        "",
        f"Generated by `benchmarks/kalman_gps_accuracy.py` on {dt.datetime.now(dt.UTC):%Y-%m-%d %H:%M} UTC "
        f"({platform.processor() or platform.machine()}, Python {platform.python_version()}). "
        f"Seeds {list(seeds)} for {', '.join(PAPER_SCENARIOS)}; seed 0 for the others.",
        "Errors above the evaluation speed gate (sideslip.evaluate.metrics). Residual colour: sum of the",
        "squared autocorrelations of the normalised innovations over 20 lags (~0.004 for white noise at",
        "5000 samples); NIS: mean squared normalised innovation (1 = consistent).  Default settings",
        "(`preset=\"auto\"`: gyro noise and process noise identified from each drive).",
        "",
        "## Beta accuracy, the paper's scenarios",
        "",
        *accuracy(PAPER_SCENARIOS, seeds),
        "",
        "## Beta accuracy, other scenarios",
        "",
        *accuracy(OTHER_SCENARIOS, (0,)),
        "",
        "## Process noise identified from the drive (issue 14)",
        "",
        "`before`: typical model-error densities (the default before issue 14, no thrust-angle term); "
        "`paper`: `preset=\"paper\"` (Table I gyro noise, typical densities, thrust-angle term); "
        "`auto`: the default, densities chosen per drive by `sideslip.methods.mkf_tuning` (gyro-"
        "innovation likelihood for the steering/yaw factor, GNSS-course likelihood-ratio set for the "
        "sideslip factor). Seed 0. Time: whole method, auto over paper (first run includes warm-up).",
        "",
        *noise_lines(),
        "",
        "## KKF: the gyro-bias walk identified from the course innovations",
        "",
        "`preset=\"auto\"` takes the factor on the typical bias-walk density with the best course-"
        "innovation likelihood (the KKF's course updates happen on straights only). On short drives "
        "the likelihood is flat; where it is not, its pick lowers the mean beta RMSE, though not on "
        "every scenario. Seed 0, right file.",
        "",
        *kkf_bias_lines(),
        "",
        "## The paper's findings (MKF with the paper preset)",
        "",
        *findings(),
        "",
        "## Table I (steady-state 1-sigma from the DARE, V = 30 m/s, noise ~ sqrt(rate))",
        "",
        "Sensor noise at 100 Hz taken from the paper's 100 Hz row (gyro 0.3 deg/s, course 0.0382 deg), our",
        "process noise (module constants). The paper's estimation errors grow as sqrt(rate) like its noise;",
        "with a fixed-density process noise (Van Loan Q_d) ours shrink with rate: the paper's Q_d must have",
        "been scaled per sample. sigma_r_hat agrees within 2-5 % at 20-100 Hz.",
        "",
        *table_one_lines(),
        "",
        "## Speed",
        "",
        *speed_lines(args.quick),
        "",
        f"Total run time {time.time() - t0:.0f} s.",
        "",
    ]
    OUT.write_text("\n".join(parts))
    print("\n".join(parts))


if __name__ == "__main__":
    main()
