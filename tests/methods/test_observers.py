"""Seed 003's sideslip observers: obs_bicycle, obs_kinematic, obs_modified(_nocomp).

Three kinds of drive:
* analytic drives built here from the linear single-track model (the observers' own model,
  noise-free) or from exact circular kinematics: the observers must be (nearly) exact there;
* the simulator's four seed 003 scenarios (nonlinear two-track truth with roll, MEMS sensor
  errors: 0.1 deg/s gyro noise and ~0.2 deg/s bias, 0.05 m/s^2 accelerometer noise and bias,
  0.1 deg steering offset, 0.5 % wheel radii): the paper's qualitative findings;
* drives with standstill, NaN gaps and a 30 % wrong cornering stiffness: finite and sane.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from scipy.linalg import expm

from sideslip.calibrate.sensors import drive_gyro_bias
from sideslip.drive import Drive, drive_from_columns, save_drive
from sideslip.evaluate import metrics
from sideslip.methods.observers import (
    ALPHA,
    obs_bicycle,
    obs_kinematic,
    obs_modified,
    obs_modified_nocomp,
    run_kinematic_observer,
)
from sideslip.methods.registry import all_methods, run_method
from sideslip.methods.roll_index import sensor_inputs
from sideslip.models.single_track import continuous
from sideslip.vehicle import G, Vehicle, load_vehicle
from tests.conftest import sim_drive
from tests.helpers import PHONE_BIAS, raw_gyro, run_cli

OBSERVERS = ("obs_bicycle", "obs_kinematic", "obs_modified", "obs_modified_nocomp")
SCENARIOS = ("step_steer", "slalom_low_mu", "banked_turn", "dlc_bank")
BANKED = ("banked_turn", "dlc_bank")
VEH = load_vehicle("seed003_sedan")


def rmse_deg(x: np.ndarray) -> float:
    return float(np.rad2deg(np.sqrt(np.mean(np.square(x)))))


def beta_rmse(method: str, drive: Drive, vehicle: Vehicle | None = None) -> float:
    veh = vehicle or load_vehicle(drive.meta["vehicle"])
    est = run_method(all_methods()[method], drive, veh)
    return rmse_deg(est["beta"] - drive["ref_beta"])


def linear_drive(steer, bank=None, speed: float = 22.2, duration: float = 12.0,
                 dt: float = 0.01, with_roll: bool = True) -> Drive:
    """Noise-free drive from the linear single-track model with suspension roll (eq 41).

    Exact ZOH discretisation; a_ym = a_y + g sin(bank + roll_sus); wheel speeds = v cos(beta).
    ``with_roll=False``: a rigid body without suspension roll (roll_sus = 0).
    """
    t = np.arange(0.0, duration, dt)
    delta = steer(t)
    phi_b = bank(t) if bank is not None else np.zeros_like(t)
    model = continuous(VEH, speed)
    aug = np.zeros((4, 4))
    aug[:2, :2], aug[:2, 2:] = model.A, model.B
    E = expm(aug * dt)
    x = np.zeros(2)
    X = np.zeros((t.size, 2))
    ay = np.zeros(t.size)
    for k in range(t.size):
        u = np.array([delta[k], np.sin(phi_b[k])])
        X[k] = x
        ay[k] = (model.C @ x + model.D @ u)[1]
        x = E[:2, :2] @ x + E[:2, 2:] @ u
    h = VEH.cg_height - VEH.roll_axis_height
    sus = np.zeros(t.size)
    phi = rate = 0.0
    for k in range(t.size):  # eq 41 driven by the measured a_ym (semi-implicit Euler)
        aym = ay[k] + G * np.sin(phi_b[k] + phi)
        rate += dt * (VEH.mass * h * aym - VEH.roll_damping * rate - VEH.roll_stiffness * phi) / VEH.roll_inertia
        phi += dt * rate
        sus[k] = phi if with_roll else 0.0
    beta, r = X[:, 0], X[:, 1]
    vx = speed * np.cos(beta)
    cols = {
        "t": t, "ax": -r * speed * np.sin(beta), "ay": ay + G * np.sin(phi_b + sus), "wz": r,
        "v_rl": vx, "v_rr": vx, "steer": delta, "ref_beta": beta, "ref_r": r,
        "ref_roll": phi_b + sus, "ref_bank": phi_b, "ref_ay": ay,
    }  # fmt: skip
    return drive_from_columns(cols, {"vehicle": "seed003_sedan"})


def _step(t: np.ndarray) -> np.ndarray:
    return np.where(t > 2.0, math.radians(2.0), 0.0)


# ------------------------------------------------------------------------------------------
# analytic cases
# ------------------------------------------------------------------------------------------
def test_bicycle_observers_exact_on_their_own_model() -> None:
    # Noise-free data from the observers' own linear model, flat road, no body roll: the error
    # starts at 0 and has no driving term, so only the ZOH of the 100 Hz inputs remains.
    # (Steady beta here is ~0.2 deg; 0.005 deg is 2.5 % of it.)
    drive = linear_drive(_step, with_roll=False)
    for fn in (obs_bicycle, obs_modified_nocomp):
        est = fn(drive, VEH)
        assert rmse_deg(est["beta"] - drive["ref_beta"]) < 0.005, fn.__name__


def test_suspension_roll_biases_the_uncompensated_observer_even_on_flat_ground() -> None:
    # Paper Fig 5b: on a flat step steer a_ym carries g sin(roll_sus) (~0.3 m/s^2 here at
    # 3 m/s^2 of a_y, roll gradient 0.44 deg per m/s^2).  Compensating by the roll index
    # (flat and steady: phi_ss, or eq 41 from the same a_ym) removes most of it.
    drive = linear_drive(_step)
    comp = rmse_deg(obs_modified(drive, VEH)["beta"] - drive["ref_beta"])
    nocomp = rmse_deg(obs_modified_nocomp(drive, VEH)["beta"] - drive["ref_beta"])
    assert comp < 0.01 < nocomp


def test_bicycle_observer_converges_from_a_wrong_state_at_the_placed_pole() -> None:
    # Start the true car in a steady turn while the observer starts from the no-slip value:
    # the error must decay like the double pole (-20 rad/s): after 0.5 s, e^{-10}(1 + 10) ~ 5e-4.
    drive = linear_drive(lambda t: np.full_like(t, math.radians(2.0)), duration=8.0)
    keep = drive.t >= 4.0  # steady state reached by the truth; restart the observer here
    sub = drive.slice(int(np.argmax(keep)), len(drive))
    est = obs_bicycle(sub, VEH)
    err = np.abs(est["beta"] - sub["ref_beta"])
    assert err[0] > 1e-3  # it did start wrong (kinematic beta vs true steady beta)
    assert err[sub.t >= sub.t[0] + 0.5].max() < 2e-3 * err[0] + 1e-6


def circle_drive(speed: float = 20.0, r: float = 0.25, beta: float = math.radians(-2.0),
                 duration: float = 30.0, ay_bias: float = 0.0, steer: float = 0.05) -> Drive:
    """Exact constant-speed circle: v_x, v_y, r constant, a_x = -r v_y, a_y = r v_x."""
    t = np.arange(0.0, duration, 0.01)
    vx, vy = speed * math.cos(beta), speed * math.sin(beta)
    one = np.ones_like(t)
    cols = {
        "t": t, "ax": -r * vy * one, "ay": r * vx * one + ay_bias, "wz": r * one,
        "v_rl": vx * one, "v_rr": vx * one, "steer": steer * one, "ref_beta": beta * one,
    }  # fmt: skip
    return drive_from_columns(cols, {"vehicle": "seed003_sedan"})


def test_kinematic_observer_converges_at_alpha_r_on_a_circle() -> None:
    # Exact kinematics, zero roll input (a_y = r v_x also makes the static bank 0).  Poles at
    # -alpha |r| = -0.5 rad/s: after 20 s the initial error has shrunk by e^{-10}(1 + 10) ~ 5e-4.
    drive = circle_drive()
    est = obs_kinematic(drive, VEH)
    err = np.abs(est["beta"] - drive["ref_beta"])
    assert err[0] > math.radians(1.0)
    late = drive.t > 20.0
    assert err[late].max() < 2e-3 * err[0] + math.radians(0.01)
    assert ALPHA * 0.25 * 20.0 >= 10.0  # the bound above assumes alpha |r| t >= 10


def test_kinematic_observer_bounded_when_lateral_velocity_is_unobservable() -> None:
    # Straight driving (r = 0) with a 0.1 m/s^2 uncorrected a_y bias: open-loop v_y would grow
    # by 0.1 m/s every second (30 s -> 3 m/s, 8.5 deg); the pull towards zero (tau = 2 s)
    # bounds it at bias x tau = 0.2 m/s = 0.6 deg at 20 m/s.
    # The observer is fed the biased a_y directly (the registered method would first remove
    # it as an apparent roll through the static bank, eq 46).
    drive = circle_drive(r=0.0, beta=0.0, ay_bias=0.1, steer=0.0)
    inp = sensor_inputs(drive)
    beta, _, vy = run_kinematic_observer(inp, VEH, inp.ay_m)
    assert np.isfinite(beta).all()
    assert np.abs(vy).max() < 0.1 * 2.0 * 1.05
    assert np.abs(beta).max() < math.radians(0.8)
    assert vy[-1] == pytest.approx(0.2, rel=0.05)


# ------------------------------------------------------------------------------------------
# the paper's findings on the simulator's seed 003 scenarios
# ------------------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def scenario_rmse() -> dict[tuple[str, str], float]:
    return {(s, m): beta_rmse(m, sim_drive(s)) for s in SCENARIOS for m in OBSERVERS}


def test_observers_accurate_on_flat_step_steer(scenario_rmse: dict) -> None:
    # Flat road, 1.5 deg step at 80 km/h (linear tyres): the model-based observers are limited by
    # the 0.1 deg steering offset and stiffness mismatch of the nonlinear truth: well below 0.2 deg.
    assert scenario_rmse[("step_steer", "obs_bicycle")] < 0.2
    assert scenario_rmse[("step_steer", "obs_modified")] < 0.2


def test_uncompensated_modified_observer_drifts_on_the_bank(scenario_rmse: dict) -> None:
    # Paper Figs 7c, 8c: the gravity in a_ym (g sin 25 deg = 4 m/s^2) biases mod-bic-w/g.
    for s in BANKED:
        comp = scenario_rmse[(s, "obs_modified")]
        nocomp = scenario_rmse[(s, "obs_modified_nocomp")]
        assert nocomp > 3.0 * comp, (s, comp, nocomp)


def test_compensated_modified_observer_is_best_on_banked_roads(scenario_rmse: dict) -> None:
    # Paper Sec. IV: mod-bic beats simp-bic, kin and mod-bic-w/g.  On the banked scenarios the
    # bank's side force misleads the flat-road bicycle model and the residual a_y errors drive
    # the kinematic observer (error ~ b/|r|), while the compensated modified observer is limited
    # by the roll estimate (~1.5 deg rms -> ~0.1 deg of beta): below 0.3 deg.
    for s in BANKED:
        ours = scenario_rmse[(s, "obs_modified")]
        assert ours < 0.3, (s, ours)
        for other in ("obs_bicycle", "obs_kinematic", "obs_modified_nocomp"):
            assert ours < scenario_rmse[(s, other)], (s, other)


def test_compensated_modified_observer_is_best_on_average(scenario_rmse: dict) -> None:
    mean = {m: np.mean([scenario_rmse[(s, m)] for s in SCENARIOS]) for m in OBSERVERS}
    assert min(mean, key=mean.__getitem__) == "obs_modified", mean


# ------------------------------------------------------------------------------------------
# robustness: wrong parameters, standstill, gaps, reversing, other drives
# ------------------------------------------------------------------------------------------
def test_observers_sane_with_cornering_stiffness_30_percent_off() -> None:
    # A 30 % stiffness error moves the model's steady beta by ~30 % of |beta| (<= 1 deg here):
    # the observers must stay finite and within 1 deg rms on the banked double lane change.
    drive = sim_drive("dlc_bank")
    wrong = VEH.with_changes(cf=0.7 * VEH.cf, cr=0.7 * VEH.cr)
    for m in OBSERVERS:
        est = run_method(all_methods()[m], drive, wrong)  # run_method checks finiteness
        limit = 2.0 if m in ("obs_modified_nocomp", "obs_kinematic") else 1.0
        assert rmse_deg(est["beta"] - drive["ref_beta"]) < limit, m


def test_observers_finite_through_standstill_and_sane_on_an_urban_drive() -> None:
    # urban_course: minivan, 20 % standstill, stop-and-go.  At standstill beta is the no-slip
    # value (|beta| <= atan(lr/L tan(delta)), tiny when standing); the model-based observers
    # stay within 1 deg rms over the drive (a_y up to ~3 m/s^2, linear range).
    drive = sim_drive("urban_course")
    veh = load_vehicle(drive.meta["vehicle"])
    still = np.abs(drive["ref_vx"]) < 0.05
    assert still.mean() > 0.05
    for m in OBSERVERS:
        est = run_method(all_methods()[m], drive, veh)
        assert np.abs(est["beta"][still]).max() < math.radians(3.0), m
        if m != "obs_kinematic":  # kinematic: error ~ a_x bias / |r| (paper: not robust)
            assert rmse_deg(est["beta"] - drive["ref_beta"]) < 1.0, m


def _with_gap(drive: Drive, t0: float, t1: float, names: tuple[str, ...]) -> Drive:
    data = dict(drive.data)
    rows = (drive.t >= t0) & (drive.t < t1)
    for name in names:
        col = np.array(data[name], dtype=float)
        col[rows] = np.nan
        data[name] = col
    return Drive(drive.t, data, drive.meta, drive.path)


def test_observers_finite_through_sensor_gaps_and_recover() -> None:
    # 1.5 s without gyro, accelerometer, steering and wheel speeds in the middle of the lane
    # change: outputs finite everywhere (held inputs, open-loop model), and after the gap the
    # run is back within 0.5 deg of the gap-free run: 2 s later for the bicycle observers
    # (poles at -20 rad/s), 8 s later for the kinematic one (poles at -alpha |r|, ~ -0.3 rad/s
    # in the manoeuvre, then the 2 s pull towards 0 on the straight).
    drive = sim_drive("dlc_bank")
    gap = _with_gap(drive, 14.0, 15.5, ("wz", "ay", "ax", "steer", "v_fl", "v_fr", "v_rl", "v_rr"))
    for m in OBSERVERS:
        ref = run_method(all_methods()[m], drive, VEH)["beta"]
        est = run_method(all_methods()[m], gap, VEH)["beta"]
        after = drive.t > (23.5 if m == "obs_kinematic" else 17.5)
        assert np.abs(est - ref)[after].max() < math.radians(0.5), m


def test_observers_finite_when_reversing_and_at_low_speed() -> None:
    # Reversing at 2 m/s with full lock: the observers do not run (below the 5 m/s gate) and
    # beta = atan2(v_y, v_x) of the no-slip bicycle, near +-pi; outputs finite.
    t = np.arange(0.0, 10.0, 0.01)
    v = -2.0 * np.minimum(t / 2.0, 1.0)
    cols = {"t": t, "ax": np.zeros_like(t), "ay": np.zeros_like(t), "wz": v * np.tan(0.5) / 2.776,
            "v_rl": v, "v_rr": v, "steer": np.full_like(t, 0.5)}
    drive = drive_from_columns(cols, {"vehicle": "seed003_sedan"})
    for m in OBSERVERS:
        est = run_method(all_methods()[m], drive, VEH)
        moving = v < -0.5
        assert np.all(np.abs(est["beta"][moving]) > 2.5), m


def test_observers_through_the_cli(tmp_path) -> None:
    drive = sim_drive("banked_turn")
    path = tmp_path / "drive.parquet"
    save_drive(drive, path)
    out = tmp_path / "est.parquet"
    args = ["estimate", path, "--vehicle", "seed003_sedan", "--out", out]
    for m in OBSERVERS:
        args += ["--method", m]
    res = run_cli(*args)
    assert res.returncode == 0, res.stderr
    res = run_cli("evaluate", path, out, "--json", tmp_path / "m.json")
    assert res.returncode == 0, res.stderr
    metrics = json.loads((tmp_path / "m.json").read_text())
    assert metrics["obs_modified"]["beta_rmse_deg"] < 0.3
    assert metrics["obs_modified_nocomp"]["beta_rmse_deg"] > metrics["obs_modified"]["beta_rmse_deg"]


def test_observers_follow_the_reference_while_reversing_with_health_flagged() -> None:
    # parking drive of the nonlinear truth model: forward at 8 m/s, stop, reverse at 2 m/s
    # with 10 deg of lock, stop.  The reference is beta = atan2(v_y, v_x) (contract), about
    # -174 deg while reversing; the observers give the no-slip bicycle's atan2 there, which
    # at 2 m/s is within a degree of it (measured 0.15 deg).  No NaN/inf anywhere; standstill
    # and reversing rows are flagged (not observed: health 0.5).
    from tests.methods.robust_drives import parking_drive

    drive = parking_drive(0)
    vehicle = load_vehicle("midsize_sedan")
    rev = drive["ref_vx"] < -1.0
    still = np.abs(drive["ref_vx"]) < 0.05
    assert rev.sum() > 1000 and still.sum() > 100
    for m in OBSERVERS:
        est = run_method(all_methods()[m], drive, vehicle)
        for name, values in est.series.items():
            assert np.all(np.isfinite(values)), (m, name)
        err = np.angle(np.exp(1j * (est["beta"][rev] - drive["ref_beta"][rev])))
        assert np.degrees(np.abs(err)).max() < 1.5, m
        h = est["health"]
        assert h.min() >= 0.0 and h.max() <= 1.0
        assert np.all(h[rev] >= 0.5) and np.all(h[still] >= 0.5), m
        assert est.params["health"]["not_observed_share"] > 0.3


@pytest.mark.parametrize("scenario", ["banked_turn", "dlc_bank"])
def test_observer_health_flags_where_the_model_stops_fitting(scenario: str) -> None:
    # on the banked roads the flat-road models read the bank's gravity as tyre force; the
    # output error shows it, and the rows the health flags (> 0.3) carry errors several times
    # those it passes (< 0.1) (measured 5-12x)
    drive = sim_drive(scenario)
    est = run_method(all_methods()["obs_modified_nocomp"], drive, VEH)
    h = est["health"]
    mv = drive["ref_vx"] > 5.0
    err = np.abs(est["beta"] - drive["ref_beta"])
    bad, good = mv & (h > 0.3), mv & (h < 0.1)
    assert bad.sum() > 100 and good.sum() > 100
    assert np.mean(err[bad]) > 3.0 * np.mean(err[good])
    # the simple bicycle observer sees the road only through its yaw-rate output: a steady
    # bank that the tyres answer leaves the yaw rate fitting, so its health cannot flag the
    # whole banked stretch (an earlier pass of "mean health > 0.5 here" came from the
    # uncorrected 0.1 deg steering offset, which flagged every row of every drive).  What it
    # must do: the rows it flags (> 0.1) carry larger errors than those it passes (measured
    # banked_turn 0.50 vs 0.25 deg, dlc_bank 0.57 vs 0.11, i.e. 1.9x and 5x: bound 1.5x), and on
    # the flat step steer its mean health stays low (measured 0.12; bound 0.2)
    est_b = run_method(all_methods()["obs_bicycle"], drive, VEH)
    h_bank = est_b["health"]
    err_b = np.abs(est_b["beta"] - drive["ref_beta"])
    flagged, passed = mv & (h_bank > 0.1), mv & (h_bank <= 0.1)
    assert flagged.sum() > 100 and passed.sum() > 100
    assert np.mean(err_b[flagged]) > 1.5 * np.mean(err_b[passed])
    step = sim_drive("step_steer")
    h_flat = run_method(all_methods()["obs_bicycle"], step, VEH)["health"]
    assert np.mean(h_flat[step["ref_vx"] > 5.0]) < 0.2


def test_observer_settings_reach_the_method_and_bad_values_say_what_is_expected() -> None:
    from sideslip.errors import InputError

    drive = sim_drive("step_steer")
    slow = run_method("obs_bicycle", drive, VEH, {"pole_rad_s": -5.0})
    assert slow.params["pole_rad_s"] == -5.0 and slow.params["settings"]["pole_rad_s"] == -5.0
    fast = run_method("obs_bicycle", drive, VEH)
    assert not np.array_equal(slow["beta"], fast["beta"])
    with pytest.raises(InputError, match=r"pole_rad_s = 3.0: expected a number in \[-1000, 0\)"):
        run_method("obs_bicycle", drive, VEH, {"pole_rad_s": 3.0})
    with pytest.raises(InputError, match=r"alpha = 0\.5: expected 1 \.\.\. 20"):
        run_method("obs_kinematic", drive, VEH, {"alpha": 0.5})


@pytest.mark.parametrize("method", ["obs_bicycle", "obs_kinematic", "obs_modified_nocomp"])
def test_observers_subtract_the_drive_zero_before_any_standstill(method: str) -> None:
    """two_turns_gyro_sf has no standstill, so the observers' standstill zeroing never starts;
    with the drive's zero (:func:`sideslip.calibrate.sensors.drive_gyro_bias`) a 3 deg/s raw
    bias leaves beta as on the drive's own gyro (the zero
    differs by its fit error only: 0.003 deg bound).  Before, the comma2k19 minute put
    obs_kinematic 24.9 deg off (benchmarks/results/realdata_check.md)."""
    drive = sim_drive("two_turns_gyro_sf")
    vehicle = load_vehicle(drive.meta["vehicle"])
    base = metrics(drive, run_method(all_methods()[method], drive, vehicle).series)
    est = run_method(all_methods()[method], raw_gyro(drive), vehicle)
    raw = metrics(drive, est.series)
    assert raw["beta_rmse_deg"] == pytest.approx(base["beta_rmse_deg"], abs=0.003)
    # the setting off: the bias is read as yaw (measured 0.046 -> 0.101, 0.442 -> 0.548,
    # 0.073 -> 0.289 deg)
    off = run_method(all_methods()[method], raw_gyro(drive), vehicle, {"zero_gyro": False})
    assert metrics(drive, off.series)["beta_rmse_deg"] > base["beta_rmse_deg"] + 0.03
    # the fit's 1 deg/s prior on the bias pulls a large one by a share of its 1-sigma only
    zero = drive_gyro_bias(drive, vehicle)
    assert est.params["gyro_zero_rad_s"] == pytest.approx(PHONE_BIAS + zero.value, abs=zero.sigma)


def test_bicycle_observer_does_not_read_a_near_neutral_files_model_error_as_sideslip() -> None:
    """CommonRoad's BMW at the grip limit (mu 0.6, rear axle saturating: an independent
    multi-body truth) with a rough file: CG 3 % of the wheelbase off and the stiffnesses
    20 / 15 % low leave it 3.0 % from neutral steer.  Placing both poles there read the
    saturated tyres' yaw-moment error as sideslip through the weak coupling a21: 7.1 deg
    RMSE against 1.2 deg with the right file.  Placed only where |a21| >= |a11 a22| / 3, the
    rough file stays within 1.5x of the right file's error (measured 0.70 against 1.21)."""
    drive = sim_drive("cr_limit_slalom")
    right = load_vehicle(drive.meta["vehicle"])
    wb = right.lf + right.lr
    rough = right.with_changes(
        mass=1.15 * right.mass, yaw_inertia=0.7 * right.yaw_inertia, lf=right.lf + 0.03 * wb,
        lr=right.lr - 0.03 * wb, cf=0.8 * right.cf, cr=0.85 * right.cr,
    )  # fmt: skip
    coupling = abs(rough.cf * rough.lf - rough.cr * rough.lr) / (
        rough.cf * rough.lf + rough.cr * rough.lr)
    assert 0.02 < coupling < 0.04  # near neutral, as the old rule's 3 % threshold
    rmse = {name: metrics(drive, run_method(all_methods()["obs_bicycle"], drive, v).series)
            ["beta_rmse_deg"] for name, v in (("right", right), ("rough", rough))}  # fmt: skip
    assert rmse["rough"] < 1.5 * rmse["right"]


def union_time_line(drive: Drive) -> Drive:
    """``drive`` as a logger that merges two buses on one time line records it: the IMU's
    rows at their times, the CAN's (wheel speeds, speed, steering) half a step later, each
    NaN on the other's rows; GNSS and the reference on the IMU's rows."""
    n, half = len(drive), 0.5 * drive.dt_median
    t = np.empty(2 * n)
    t[0::2], t[1::2] = drive.t, drive.t + half
    cols = {}
    for name in drive.data:
        col = np.full(2 * n, np.nan)
        imu_row = name in ("ax", "ay", "az", "wx", "wy", "wz") or name.startswith(("gnss_", "ref_"))
        col[slice(0 if imu_row else 1, None, 2)] = drive[name]
        cols[name] = col
    return drive_from_columns({"t": t, **cols}, dict(drive.meta))


@pytest.mark.parametrize(("method", "bound"), [("obs_modified_nocomp", 0.3), ("obs_bicycle", 0.2)])
def test_a_union_time_line_of_two_buses_is_observed_as_logged(method, bound) -> None:
    """urban_course on a union time line (IMU and CAN rows interleaved, NaN between each
    one's samples): a sample is held for up to 1.5 of its own spacings, so the correction runs
    on every row.  Before, every row without a gyro and a_y sample ran open loop and the
    modified observer read 0.412 deg (0.209 as logged; the real Revs lap so merged: 20.8
    against 1.18).  Measured now: obs_modified_nocomp 0.209, obs_bicycle 0.149 (0.149 as
    logged).  Bounds: between the two, with margin for the half-step of extra hold."""
    drive = sim_drive("urban_course")
    merged = union_time_line(drive)
    vehicle = load_vehicle(drive.meta["vehicle"])
    est = run_method(method, merged, vehicle)
    assert metrics(merged, est.series)["beta_rmse_deg"] < bound
    assert all(np.isfinite(v).all() for v in est.series.values())
