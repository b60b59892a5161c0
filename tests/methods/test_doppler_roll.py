"""Roll (eq 16) and the lateral-accelerometer error scan (eqs 17-19) of seed 000."""

from __future__ import annotations

import numpy as np
import pytest

from sideslip.drive import Drive
from sideslip.methods.doppler_roll import (
    CurveWindow,
    _turned,
    roll_from_lateral,
    scan_ay_bias,
)
from sideslip.methods.doppler_slip import run_doppler_slip
from sideslip.simulate.run import drive_from_truth
from sideslip.simulate.sensors import SensorConfig
from sideslip.vehicle import G, load_vehicle
from tests.methods.test_doppler_slip import VEHICLE, steady_drive, steady_truth

PAPER_DGY = 0.25  # m/s^2: the lateral-accelerometer error seed 000 identified on its MEMS IMU


def test_roll_from_lateral_inverts_the_specific_force_exactly() -> None:
    # the accelerometer of a body rolled by phi reads a_y cos(phi) + g sin(phi) + bias
    phi = np.radians(np.array([-8.0, -2.0, 0.0, 3.0, 6.0]))
    a_y = np.array([-4.0, 2.0, 0.0, 4.0, 6.0])
    r, v = a_y / 15.0, np.full(5, 15.0)
    reading = a_y * np.cos(phi) + G * np.sin(phi) + 0.2
    assert np.allclose(roll_from_lateral(reading, r, v, ay_bias=0.2), phi, atol=1e-12)



def test_the_scans_turn_integral_is_the_gyro_over_cos_roll() -> None:
    # a body rolled by phi turns by the horizontal rate r / cos(phi): for every candidate
    # delta G_y the kernel's trapezoid equals the integral with the roll of roll_from_lateral
    # (cos(asin(y) - c) taken algebraically), to rounding; a gap's NaN comes out as NaN
    rng = np.random.default_rng(3)
    t = np.cumsum(rng.uniform(0.005, 0.015, 400))
    a = rng.normal(0.0, 4.0, t.size)
    ay_m = a + rng.normal(0.0, 0.5, t.size)
    rate = rng.normal(0.2, 0.1, t.size)
    grid = np.arange(-1.5, 1.505, 0.01)
    phi = roll_from_lateral(ay_m[:, None], a[:, None], np.ones(1)[None, :], -grid[None, :])
    f = rate[:, None] / np.maximum(np.cos(phi), 0.1)
    direct = np.sum(0.5 * (f[1:] + f[:-1]) * np.diff(t)[:, None], axis=0)
    assert np.allclose(_turned(t, rate, ay_m, a, grid), direct, rtol=1e-12, atol=1e-12)
    ay_m[100] = np.nan
    assert np.isnan(_turned(t, rate, ay_m, a, grid)).all()

def test_roll_sign_is_iso_right_side_down_positive() -> None:
    # standing on a road whose right edge is lower: a_y,m = +g sin(phi) > 0 -> roll > 0
    assert roll_from_lateral(np.array([G * np.sin(0.05)]), np.zeros(1), np.zeros(1))[0] > 0


def _with_extra_ay_error(drive: Drive, value: float) -> Drive:
    return Drive(drive.t, {**drive.data, "ay": drive.data["ay"] + value}, drive.meta, drive.path)


@pytest.mark.parametrize("extra", [0.0, PAPER_DGY, -0.4])
def test_scan_finds_the_accelerometer_error_with_ideal_sensors(extra: float) -> None:
    # ideal sensors on the analytic drive: only the scan's grid and the a_y ~ psi' V shortcut
    # (v_y' dropped, 0.5 s smoothing) limit it; 0.02 m/s^2 is 0.12 deg of roll
    vehicle = load_vehicle(VEHICLE)
    drive = drive_from_truth(steady_truth(vehicle), vehicle, 0, SensorConfig.noiseless(), "x",
                             VEHICLE)  # fmt: skip
    est = run_doppler_slip(_with_extra_ay_error(drive, extra), vehicle)
    assert est.params["dGy_mps2"] == pytest.approx(-extra, abs=0.02)
    assert est.params["dGy_note"] == ""


@pytest.mark.parametrize("seed", [0, 1])
def test_scan_with_default_mems_sensors_beats_no_correction(seed: int) -> None:
    # default sensors (gyro noise/bias walk/scale, Doppler 0.05 m/s, 0.2 % multipath) plus the
    # paper's 0.25 m/s^2 error: the heading closure of ~10 curves is good to ~0.1 deg each,
    # so delta G_y to ~0.05 m/s^2 (0.3 deg of roll), against 1.5 deg uncorrected
    drive = _with_extra_ay_error(steady_drive(seed), PAPER_DGY)
    vehicle = load_vehicle(VEHICLE)
    est = run_doppler_slip(drive, vehicle)
    truth_dgy = -(drive.meta["truth_sensor"]["accel_bias_mean"][1] + PAPER_DGY)
    assert est.params["dGy_mps2"] == pytest.approx(truth_dgy, abs=0.06)
    assert est.params["dGy_std_mps2"] < 0.1
    moving = drive["ref_vx"] > 5.0
    err = est["roll"][moving] - drive["ref_roll"][moving]
    raw = est["roll_raw"][moving] - drive["ref_roll"][moving]  # delta G_y = 0
    assert abs(np.mean(err)) < 0.5 * abs(np.mean(raw))
    assert abs(np.degrees(np.mean(err))) < 0.4


def _windows_and_signals(
    phis: list[float], turn: float = np.pi / 2, closure_noise: list[float] | None = None
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, list[CurveWindow]]:
    """Synthetic curves at 15 m/s with body roll phi, gyro w_z = Omega cos(phi), a_y = 0."""
    dt, dur = 0.01, 10.0
    n_per = int(dur / dt) + 200
    t = np.arange(len(phis) * n_per) * dt
    rate = np.zeros(t.size)
    ay_m = np.zeros(t.size)
    windows = []
    for k, phi in enumerate(phis):
        a = k * n_per
        sign = 1.0 if k % 2 == 0 else -1.0
        seg = slice(a + 100, a + 100 + int(dur / dt))
        omega = sign * turn / dur
        rate[seg] = omega * np.cos(phi)
        ay_m[seg] = G * np.sin(phi) * sign  # body rolls out of the turn
        noise = closure_noise[k] if closure_noise else 0.0
        windows.append(CurveWindow(a, a + n_per - 1, sign * turn + noise))
    return t, rate, ay_m, np.zeros(t.size), windows


def test_scan_on_synthetic_curves_and_the_combination_rules() -> None:
    phis = [0.06, 0.09, 0.05, 0.08, 0.07]
    t, rate, ay_m, cen, windows = _windows_and_signals(phis)
    for combine in ("joint", "weighted_median", "median", "mean"):
        res = scan_ay_bias(t, rate, ay_m, cen, windows, combine=combine)
        assert res.ay_bias == pytest.approx(0.0, abs=0.015), combine
    # an accelerometer error of 0.3 m/s^2 is found back
    res = scan_ay_bias(t, rate, ay_m + 0.3, cen, windows)
    assert res.ay_bias == pytest.approx(0.3, abs=0.015)
    assert res.params()["dGy_mps2"] == pytest.approx(-0.3, abs=0.015)
    with pytest.raises(ValueError, match="combine must be one of"):
        scan_ay_bias(t, rate, ay_m, cen, windows, combine="mode")


def test_one_bad_curve_is_dropped_by_the_joint_fit() -> None:
    phis = [0.06, 0.09, 0.05, 0.08, 0.07, 0.06]
    noise = [0.0, 0.0, 0.0, np.radians(1.5), 0.0, 0.0]  # one curve's end hit by multipath
    t, rate, ay_m, cen, windows = _windows_and_signals(phis, closure_noise=noise)
    res = scan_ay_bias(t, rate, ay_m + 0.2, cen, windows)
    assert res.n_curves == 5
    assert res.ay_bias == pytest.approx(0.2, abs=0.03)


def test_flat_curves_carry_no_roll_information_and_the_correction_is_not_applied() -> None:
    # roll 0.5 deg: d(turn)/d(delta) ~ turn phi / g is 1.6e-3 rad per m/s^2, below the noise
    phis = [0.009, 0.008, 0.009, 0.008, 0.009, 0.008]
    noise = list(np.radians([0.1, 0.1, -0.1, -0.1, 0.1, -0.1]))  # not a scale factor
    t, rate, ay_m, cen, windows = _windows_and_signals(phis, closure_noise=noise)
    res = scan_ay_bias(t, rate, ay_m, cen, windows)
    assert res.ay_bias == 0.0
    assert "too uncertain" in res.reason


def test_too_few_curves_give_zero_and_say_why() -> None:
    # three curves cannot pin delta G_y and the residual gyro scale with any redundancy
    t, rate, ay_m, cen, windows = _windows_and_signals([0.06, 0.09, 0.05])
    res = scan_ay_bias(t, rate, ay_m + 0.3, cen, windows)
    assert res.ay_bias == 0.0
    assert "only 3 usable curves" in res.reason


def test_no_curves_gives_zero_and_says_why() -> None:
    t = np.arange(0.0, 10.0, 0.01)
    res = scan_ay_bias(t, np.zeros(t.size), np.zeros(t.size), np.zeros(t.size), [])
    assert res.ay_bias == 0.0 and res.n_curves == 0
    assert "no curve window" in res.reason


# --- Monte-Carlo honesty of the identified parameters ----------------------------------------
# (scenario, duration s or None, seed, extra a_y error m/s^2): seed 000's urban course and
# highway, seed 004's suburban drive with 30 s outages, and a stop-and-go drive (the first 10
# minutes of the endurance route: town blocks with stops, country road); one run carries an
# extra 0.10 m/s^2 accelerometer error (the size the issue measured).
MC_RUNS = (
    ("urban_course", None, 0, 0.0), ("urban_course", None, 1, 0.0),
    ("urban_course", None, 2, 0.10), ("urban_highway", None, 0, 0.0),
    ("suburban_outages", None, 0, 0.0), ("endurance", 600.0, 0, 0.0),
    ("endurance", 600.0, 1, 0.0), ("endurance", 600.0, 2, 0.10),
)  # fmt: skip


def _true_k(drive: Drive, lr: float) -> float:
    """The slip gain of the truth: LS slope of the true rear-axle sideslip on the true
    G_y = r V + g sin(roll), over moving rows in curves (the rows eq 20 uses)."""
    vx, r = drive["ref_vx"], drive["ref_r"]
    beta_r = drive["ref_beta"] - lr * r / np.maximum(vx, 1.0)
    gy = r * vx + G * np.sin(drive["ref_roll"])
    sel = (vx > 5.0) & (np.abs(gy) > 0.5)
    A = np.column_stack([gy[sel], np.ones(int(sel.sum()))])
    return -float(np.linalg.lstsq(A, beta_r[sel], rcond=None)[0][0])


@pytest.fixture(scope="module")
def mc_results() -> list[dict[str, float]]:
    from sideslip.simulate import simulate

    out = []
    for scenario, duration, seed, extra in MC_RUNS:
        drive = _with_extra_ay_error(simulate(scenario, seed=seed, duration_s=duration), extra)
        vehicle = load_vehicle(drive.meta["vehicle"])
        p = run_doppler_slip(drive, vehicle).params
        ts = drive.meta["truth_sensor"]
        out.append({
            "dgy": p["dGy_mps2"], "dgy_joint": p["dGy_joint_mps2"], "dgy_std": p["dGy_std_mps2"],
            "dgy_applied": p["ay_bias_applied"],
            # what a constant-bias a_y model should find: bias + misalignment x g, plus extra
            "dgy_true": -(ts["ay_bias_level"] + extra),
            "k": p["K"], "k_std": p["K_std"], "k_true": _true_k(drive, vehicle.lr),
            "gs": p["gyro_scale"], "gs_std": p["gyro_scale_sigma"],
            "gs_true": 1.0 + ts["gyro_scale_factor"],
            "ws": p["wheel_speed_scale"], "ws_std": p["wheel_speed_scale_sigma"],
            "ws_true": 1.0 + float(np.mean(ts["wheel_scale_factor"][2:])),  # rear wheels used
        })
    return out


@pytest.mark.slow
def test_applied_dgy_is_within_015_of_the_truth_or_rejected(mc_results: list) -> None:
    # the acceptance: on urban, outage and stop-and-go drives delta G_y is within
    # 0.15 m/s^2 (0.9 deg of roll) of the truth, or it is not applied (reason in the params)
    for r in mc_results:
        if r["dgy_applied"]:
            assert abs(r["dgy"] - r["dgy_true"]) <= 0.15, r
        else:
            assert r["dgy"] == 0.0


@pytest.mark.slow
@pytest.mark.parametrize("name", ["dgy_joint", "k", "gs", "ws"])
def test_identified_parameters_one_sigma_contains_the_truth(mc_results: list, name: str) -> None:
    # an honest 1-sigma holds the truth in ~68 % of runs and (almost) never misses by 3 sigma;
    # with 8 runs, at least half inside 1 sigma and all inside 3 sigma (a binomial 68 % gives
    # fewer than 4 of 8 with probability 0.07; a 3-sigma miss has probability 0.003 per run)
    key_true = "dgy_true" if name == "dgy_joint" else f"{name}_true"
    key_std = "dgy_std" if name == "dgy_joint" else f"{name}_std"
    rows = [r for r in mc_results if np.isfinite(r[key_std])]
    assert len(rows) >= 6
    z = np.array([abs(r[name] - r[key_true]) / r[key_std] for r in rows])
    assert np.all(z <= 3.0), z
    assert np.mean(z <= 1.0) >= 0.5, z
