"""The CommonRoad multi-body adapter: sign conventions, kinematic consistency, vehicle preset."""

from __future__ import annotations

import functools
from importlib import resources

import numpy as np
import pytest
from scipy.integrate import cumulative_trapezoid

pytest.importorskip("vehiclemodels", reason="needs the optional commonroad extra (commonroad-vehicle-models)")

from sideslip.errors import InputError
from sideslip.simulate import SensorConfig, simulate
from sideslip.simulate import commonroad as cr
from sideslip.simulate.truth import Truth
from sideslip.vehicle import G, load_vehicle
from tests.conftest import sim_drive

pytestmark = pytest.mark.commonroad


@functools.lru_cache(maxsize=4)
def step_truth() -> Truth:
    """Left step steer (1.15 deg road wheel) at 80 km/h: the cached cr_step_steer truth."""
    return cr.scenario_truth("cr_step_steer")


def test_left_turn_is_positive_yaw_rate_and_rolls_right_side_down() -> None:
    truth = step_truth()
    late = truth.t > 6.0  # steady state after the step at 2 s
    assert np.all(truth.steer[late] > 0.019)  # steer tracked: wanted 0.02 rad, left
    assert np.all(truth.r[late] > 0.1) and np.all(truth.ay[late] > 3.0)
    # ISO 8855: a left turn rolls the body right side down = positive roll.
    assert np.all(truth.roll[late] > 0.02)
    # The right (outer) wheels roll faster than the left (inner) ones.
    fl, fr, rl, rr = truth.wheel_speed[late].T
    assert np.all(fr > fl) and np.all(rr > rl)
    # ... by about r * track (rear: no steer), within 10 % (tyre slip, compliance).
    p = cr.parameters("vw_vanagon")
    np.testing.assert_allclose(rr - rl, truth.r[late] * p.T_r, rtol=0.1)
    # The GNSS-style course turns left too: n increases when heading East and turning left.
    assert truth.n[-1] > 10.0


def test_braking_pitches_nose_down_positive() -> None:
    truth = cr.commonroad_truth(
        0.0, accel=lambda t: -4.0 if t > 1.0 else 0.0, duration_s=3.0, initial_speed=20.0
    )
    assert truth.ax[-1] < -3.0
    assert truth.pitch[-1] > 0.005  # ISO: nose down positive
    # Straight braking: no turning.  CommonRoad's multi-body model has a small self-sustained
    # lateral oscillation on a straight road (about 1.7 Hz, roll +-0.3 deg, r +-0.004 rad/s
    # while it builds up; the same with LSODA and Radau, every parameter set): bound it.
    assert np.max(np.abs(truth.r)) < 0.006 and np.max(np.abs(truth.roll)) < 0.008


def test_truth_is_kinematically_consistent() -> None:
    truth = step_truth()
    t = truth.t
    # Positions: integral of the heading-frame velocities rotated by yaw.  LSODA (rtol 1e-6)
    # plus the trapezoid (dt^2/12 |jerk| T ~ 1e-4 m): 0.01 m over 220 m.
    ve = np.cos(truth.yaw) * truth.vx - np.sin(truth.yaw) * truth.vy
    vn = np.sin(truth.yaw) * truth.vx + np.cos(truth.yaw) * truth.vy
    np.testing.assert_allclose(truth.e, cumulative_trapezoid(ve, t, initial=0), atol=0.01)
    np.testing.assert_allclose(truth.n, cumulative_trapezoid(vn, t, initial=0), atol=0.01)
    # Yaw rate = d(yaw)/dt: central differences, error dt^2/6 times
    # the third derivative of yaw (up to 4e-4 rad/s during the 0.1 s steering ramp).
    np.testing.assert_allclose(np.gradient(truth.yaw, t)[1:-1], truth.r[1:-1], atol=5e-4)
    # a_y = dvy/dt + r vx and acc_enu = d(v_enu)/dt, checked in integral form: the model's
    # straight-road oscillation has 10 ms kinks in a_y that spoil finite differences.
    # Trapezoid on kinked signals over 10 s: within 2e-3 m/s.
    vy = truth.vy[0] + cumulative_trapezoid(truth.ay - truth.r * truth.vx, t, initial=0)
    np.testing.assert_allclose(vy, truth.vy, atol=2e-3)
    np.testing.assert_allclose(ve[0] + cumulative_trapezoid(truth.acc_enu[:, 0], t, initial=0), ve, atol=2e-3)
    np.testing.assert_allclose(vn[0] + cumulative_trapezoid(truth.acc_enu[:, 1], t, initial=0), vn, atol=2e-3)
    # Body yaw rate = r cos(roll) cos(pitch) - pitch rate sin(roll) (Euler rates).
    assert np.max(np.abs(truth.omega_body[:, 2] - truth.r)) < 1e-3


def test_preset_file_is_the_derived_vehicle() -> None:
    for name in cr.PARAMETER_SETS:
        text = (resources.files("sideslip") / "presets" / f"commonroad_{name}.toml").read_text()
        assert text == cr.vehicle_toml(name), f"regenerate commonroad_{name}.toml"
        vehicle = load_vehicle(f"commonroad_{name}")
        for key, value in cr.vehicle_values(name).items():
            if key != "wheel_radius":
                assert getattr(vehicle, key) == pytest.approx(value, rel=1e-8), key


def test_cornering_stiffness_is_per_axle_tyre_slope_at_static_load() -> None:
    from vehiclemodels.utils.tire_model import formula_lateral

    p = cr.parameters("vw_vanagon")
    vehicle = load_vehicle("commonroad_vw_vanagon")
    alpha = 1e-4
    for axle_load, stiffness in (
        (p.m * cr.CR_G * p.b / (p.a + p.b), vehicle.cf),
        (p.m * cr.CR_G * p.a / (p.a + p.b), vehicle.cr),
    ):
        # Two tyres per axle, each at half the axle load; CommonRoad's F_y is -C alpha.
        slope = -2 * formula_lateral(alpha, 0.0, axle_load / 2, p.tire)[0] / alpha
        assert stiffness == pytest.approx(slope, rel=1e-3)


def test_circle_steady_state_agrees_with_the_derived_vehicle_file() -> None:
    drive = sim_drive("cr_circle", 0)
    vehicle = load_vehicle(drive.meta["vehicle"])
    steady = drive.t > 40.0
    v, r = drive["ref_vx"][steady].mean(), drive["ref_r"][steady].mean()
    delta = 0.05
    # Linear single-track steady state r = v delta / (L (1 + K_us v^2 / L)); the multi-body
    # model differs by load transfer, compliance and camber: agree within 10 %.
    kus = vehicle.understeer_gradient
    r_lin = v * delta / (vehicle.wheelbase * (1 + kus * v**2 / vehicle.wheelbase))
    assert r == pytest.approx(r_lin, rel=0.1)
    # Static roll gain m h / k of the file vs the model's roll: within 20 % (the file ignores
    # the unsprung masses and the compliant joints).
    ay, roll = drive["ref_ay"][steady].mean(), drive["ref_roll"][steady].mean()
    assert roll == pytest.approx(vehicle.static_roll_gain * ay, rel=0.2)


def test_cr_scenarios_are_reachable_from_simulate() -> None:
    drive = sim_drive("cr_step_steer", 0)
    assert len(drive) == 1001 and drive.dt_median == pytest.approx(0.01)
    assert drive.meta["scenario"] == "cr_step_steer"
    assert drive.meta["vehicle"] == "commonroad_vw_vanagon"
    load_vehicle(drive.meta["vehicle"])
    for name in (
        "ax",
        "ay",
        "wz",
        "v_rl",
        "v_can",
        "steer",
        "gnss_e",
        "gnss_ve",
        "ref_beta",
        "ref_roll",
        "ref_ay",
    ):
        assert name in drive, name
    # Accelerometer (IMU at the CG) minus the reference: gravity through roll + drawn offset.
    ts = drive.meta["truth_sensor"]
    rows = np.flatnonzero(np.isfinite(drive["ay"]))
    resid = drive["ay"][rows] - drive["ref_ay"][rows] - G * np.sin(drive["ref_roll"][rows])
    # Mean: bias + misalignment (ay_bias_level) + scale factor * mean a_y (|sf| ~ 0.003);
    # noise 0.05/sqrt(1001) = 0.002: within 0.015 m/s^2.
    assert np.mean(resid) == pytest.approx(ts["ay_bias_level"], abs=0.015)


def test_cr_slalom_alternates_and_stays_finite() -> None:
    drive = sim_drive("cr_slalom", 0)
    r = drive["ref_r"]
    assert r.max() > 0.1 and r.min() < -0.1
    for name in drive.data:
        assert not np.isinf(drive[name]).any(), name


def test_friction_moves_the_grip_limit_and_keeps_the_cornering_stiffness() -> None:
    p = cr.parameters("bmw_320i")
    q = cr.with_friction(p, 0.6)
    assert q.tire.p_dy1 == pytest.approx(0.6)
    assert q.tire.p_dx1 == pytest.approx(p.tire.p_dx1 * 0.6 / p.tire.p_dy1)
    assert q.tire.p_ky1 == p.tire.p_ky1  # K_y = p_ky1 F_z: the vehicle file stays right
    assert p.tire.p_dy1 > 1.0  # the cached set is untouched
    with pytest.raises(ValueError, match=r"mu = -1.0: expected a number > 0"):
        cr.with_friction(p, -1.0)


@pytest.mark.parametrize(("name", "beta_min_deg"), [("cr_limit_slalom", 4.0), ("cr_limit_ramp", 0.8)])
def test_limit_scenarios_reach_the_grip_of_a_mu_06_road(name: str, beta_min_deg: float) -> None:
    """Both drive the tyres to the limit of mu 0.6: a_y within 10 % of mu g (never beyond it by
    more than the model's load transfer and camber allow); the slalom saturates the rear axle
    (large beta), the ramp the front (understeer, small beta); both carry multipath bursts."""
    drive = sim_drive(name, 0)
    ay = np.abs(drive["ref_ay"])
    assert 0.9 * 0.6 * G < ay.max() < 1.1 * 0.6 * G
    assert np.degrees(np.abs(drive["ref_beta"])).max() > beta_min_deg
    assert drive.meta["truth_sensor"]["gnss_burst_epochs"] > 0
    assert drive.meta["vehicle"] == "commonroad_bmw_320i"


def test_cr_scenarios_refuse_another_vehicle() -> None:
    with pytest.raises(InputError, match=r"scenario 'cr_circle'.*expected no vehicle"):
        simulate("cr_circle", vehicle=load_vehicle("seed003_sedan"))


def test_commonroad_truth_refuses_standstill_and_ambiguous_inputs() -> None:
    with pytest.raises(ValueError, match=r"initial speed 0.0 m/s: expected >= 1.0 m/s"):
        cr.commonroad_truth(0.0, speed=0.0)
    with pytest.raises(ValueError, match="exactly one of speed= and accel="):
        cr.commonroad_truth(0.0, speed=10.0, accel=0.0)
    with pytest.raises(ValueError, match="unknown CommonRoad parameter set 'tesla'"):
        cr.commonroad_truth(0.0, speed=10.0, params="tesla")


def test_commonroad_drive_with_noiseless_sensors_reproduces_the_truth() -> None:
    truth = step_truth()
    drive = cr.commonroad_drive(truth, config=SensorConfig.noiseless(), scenario="cr_test")
    np.testing.assert_allclose(drive["wz"], truth.omega_body[:, 2], atol=1e-12)
    rows = np.flatnonzero(np.isfinite(drive["steer"]))
    np.testing.assert_allclose(drive["steer"][rows], truth.steer[rows], atol=1e-12)
    assert np.isfinite(drive["ref_beta"]).all()
