"""The GNSS measurement layer: course noise model, gates, defaults, Gauss-Markov discretisation."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sideslip import gnss
from sideslip.drive import drive_from_columns
from sideslip.frames import wrap_angle
from sideslip.vehicle import load_vehicle


def _drive(speed: float = 20.0, course: float = 0.4, vel_std: float | None = 0.2, n: int = 200,
           seed: int = 0, doppler: bool = True) -> object:  # fmt: skip
    rng = np.random.default_rng(seed)
    t = np.arange(n) * 0.1
    cols: dict[str, np.ndarray] = {"t": t, "v_rl": np.full(n, speed), "v_rr": np.full(n, speed)}
    if doppler:
        cols["gnss_ve"] = speed * math.cos(course) + rng.normal(0, vel_std or 0.1, n)
        cols["gnss_vn"] = speed * math.sin(course) + rng.normal(0, vel_std or 0.1, n)
        if vel_std is not None:
            cols["gnss_vel_std"] = np.full(n, vel_std)
    cols["gnss_e"] = speed * math.cos(course) * t
    cols["gnss_n"] = speed * math.sin(course) * t
    return drive_from_columns(cols, {})


def test_course_sigma_is_velocity_sigma_over_speed_with_floor() -> None:
    sig = gnss.course_sigma(np.array([0.2, 0.0]), np.array([20.0, 20.0]))
    assert sig[0] == pytest.approx(math.hypot(0.01, gnss.COURSE_SIGMA_FLOOR_RAD))
    assert sig[1] == pytest.approx(gnss.COURSE_SIGMA_FLOOR_RAD)


def test_course_samples_scatter_matches_their_sigma() -> None:
    d = _drive(vel_std=0.3, n=4000, seed=1)
    cs = gnss.course_samples(d)
    err = cs.course - 0.4
    # 4000 samples: the empirical 1-sigma is known to ~1.1 %; 5 % is > 4 sigma
    assert np.std(err) == pytest.approx(float(np.median(cs.sigma)), rel=0.05)


def test_receiver_sigma_default_when_column_absent_or_bad() -> None:
    d = _drive(vel_std=None)
    cs = gnss.course_samples(d)
    expected = math.hypot(gnss.VEL_SIGMA_DEFAULT_M_S / 20.0, gnss.COURSE_SIGMA_FLOOR_RAD)
    np.testing.assert_allclose(cs.speed, 20.0, atol=0.5)
    assert cs.sigma == pytest.approx(np.full(cs.sigma.size, expected), rel=0.03)


def test_course_gates_by_speed_and_receiver_sigma_and_flips_reversing() -> None:
    slow = _drive(speed=2.0)
    assert gnss.course_samples(slow, min_speed=3.0).rows.size == 0
    poor = _drive(speed=4.0, vel_std=0.5)  # 0.5 / 4 = 7 deg > 5 deg
    assert gnss.course_samples(poor).rows.size == 0
    d = _drive(speed=10.0, vel_std=0.05)
    signed = np.full(len(d), -10.0)  # wheels say reversing: the body points the other way
    cs = gnss.course_samples(d, signed)
    assert cs.reversing.all()
    np.testing.assert_allclose(np.cos(cs.course - (0.4 - math.pi)), 1.0, atol=1e-3)
    # the vehicle's own speed must confirm the GNSS speed
    assert gnss.course_samples(d, np.full(len(d), 1.0)).rows.size == 0


def test_positions_used_when_no_doppler_with_their_fix_to_fix_sigma() -> None:
    d = _drive(doppler=False)
    vel = gnss.velocity_samples(d)
    assert vel.source == "positions"
    np.testing.assert_allclose(vel.speed, 20.0, rtol=1e-9)
    # 10 Hz fixes: differenced over the 1 s baseline (DIFFERENCE_BASELINE_S), centred
    assert vel.sigma[0] == pytest.approx(math.sqrt(2) * 0.45 * gnss.POS_SIGMA_DEFAULT_M / 1.0)
    assert gnss.doppler_samples(d).rows.size == 0


def test_missing_column_reads_as_nan_and_positions_default_sigma() -> None:
    d = _drive()
    assert np.isnan(gnss.column(d, "gnss_pos_std")).all()
    pos = gnss.position_samples(d)
    assert pos.median_sigma() == gnss.POS_SIGMA_DEFAULT_M


def test_gauss_markov_discretisation_keeps_the_stationary_variance() -> None:
    phi, q = gnss.gauss_markov(0.1, 60.0, 1.2)
    assert phi == pytest.approx(math.exp(-0.1 / 60.0))
    # stationary: var = phi^2 var + q  for any step
    assert phi**2 * 1.44 + q == pytest.approx(1.44, rel=1e-12)
    # two half steps compose to one full step (exact discretisation, unlike 1 - dt/tau)
    ph, qh = gnss.gauss_markov(0.05, 60.0, 1.2)
    assert ph * ph == pytest.approx(phi, rel=1e-12)
    assert ph * ph * qh + qh == pytest.approx(q, rel=1e-9)


def test_course_at_cg_drops_a_multipath_sample() -> None:
    d = _drive(vel_std=0.05, n=300)
    cols = {name: np.array(d[name]) for name in d.columns()}
    cols["wz"] = np.zeros(len(d))
    ang = math.radians(10.0)
    ve, vn = cols["gnss_ve"][150], cols["gnss_vn"][150]
    cols["gnss_ve"][150] = ve * math.cos(ang) - vn * math.sin(ang)
    cols["gnss_vn"][150] = ve * math.sin(ang) + vn * math.cos(ang)
    bad = drive_from_columns(cols, {})
    cm = gnss.course_at_cg(bad, load_vehicle("blazer_suv"), np.full(len(bad), 20.0))
    assert np.isnan(cm.course[150])
    assert np.isfinite(cm.course[149]) and np.isfinite(cm.course[151])


def _circle_fixes(rate_hz: float, radius: float = 80.0, speed: float = 20.0, duration: float = 20.0,
                  noise_m: float = 0.0, seed: int = 0) -> tuple[object, float]:  # fmt: skip
    """A 100 Hz drive on a left circle whose fixes arrive at ``rate_hz`` (no Doppler)."""
    rng = np.random.default_rng(seed)
    t = np.arange(round(duration * 100) + 1) * 0.01
    ang = speed / radius * t
    cols: dict[str, np.ndarray] = {"t": t, "v_rl": np.full(t.size, speed), "v_rr": np.full(t.size, speed)}
    step = round(100 / rate_hz)
    fix = np.arange(t.size) % step == 0
    cols["gnss_e"] = np.where(fix, radius * np.sin(ang) + rng.normal(0, noise_m, t.size), np.nan)
    cols["gnss_n"] = np.where(fix, radius * (1 - np.cos(ang)) + rng.normal(0, noise_m, t.size), np.nan)
    return drive_from_columns(cols, {}), speed / radius


def test_fast_fixes_give_a_centred_course_over_a_one_second_baseline() -> None:
    """20 Hz fixes on a circle (r = 0.25 rad/s): the course comes from the fixes half a
    second before and after each one, so it is the tangent at the fix (a chord's direction is
    the tangent at its middle on a circle), not 0.125 rad behind it; 0.1 m of fix noise over a
    1 s (20 m) baseline turns it by ~0.4 deg, where two fixes 50 ms apart give ~8 deg."""
    drive, rate = _circle_fixes(20.0)
    vel = gnss.velocity_samples(drive)
    truth = rate * drive.t[vel.rows]
    assert np.max(np.abs(wrap_angle(np.arctan2(vel.vn, vel.ve) - truth))) < 1e-9
    assert np.hypot(vel.ve, vel.vn) == pytest.approx(20.0 * math.sin(0.125) / 0.125, rel=1e-9)
    assert drive.t[vel.rows][0] == pytest.approx(0.5) and drive.t[vel.rows][-1] == pytest.approx(19.5)
    noisy, _ = _circle_fixes(20.0, noise_m=0.1, seed=3)
    vel = gnss.velocity_samples(noisy)
    err = wrap_angle(np.arctan2(vel.vn, vel.ve) - rate * noisy.t[vel.rows])
    assert math.degrees(np.std(err)) < 0.6


def test_slow_fixes_are_differenced_with_the_previous_one() -> None:
    drive, rate = _circle_fixes(1.0)
    vel = gnss.velocity_samples(drive)
    # stamped at the later fix: the chord's direction lags the tangent by half a step
    assert drive.t[vel.rows][0] == pytest.approx(1.0)
    course = np.arctan2(vel.vn, vel.ve)
    assert np.allclose(wrap_angle(course - rate * (drive.t[vel.rows] - 0.5)), 0.0, atol=1e-9)


def test_course_from_fixes_spans_ten_metres_and_resists_a_repeated_first_fix() -> None:
    """A receiver that repeats its first position (or two noisy fixes 50 ms apart) gives no
    course; the first 10 m of fixes give the straight line's 0.4 rad."""
    d = _drive(doppler=False)
    e, n = d["gnss_e"].copy(), d["gnss_n"].copy()
    e[1], n[1] = e[0] + 0.05, n[0] - 0.05  # a second fix a few cm off the first, sideways
    from dataclasses import replace

    d = replace(d, data={**d.data, "gnss_e": e, "gnss_n": n})
    course, t_a, t_b = gnss.course_from_fixes(d)
    assert course == pytest.approx(0.4, abs=0.01)
    assert t_b - t_a == pytest.approx(0.6)  # 12 m at 20 m/s: the first fix beyond 10 m
    assert gnss.course_from_fixes(_drive(doppler=False, n=2)) is None


def test_course_from_fixes_waits_for_the_wheels_to_move() -> None:
    """A car standing for 5 s with multipath fixes 9-12 m off (urban_course with 5 % multipath
    once gave a course 174 deg wrong this way), then driving off at 10 m/s along 0.4 rad: only a
    baseline the wheels confirm counts."""
    t = np.arange(0.0, 15.0, 0.05)
    moving = t >= 5.0
    speed = np.where(moving, 10.0, 0.0)
    travelled = np.where(moving, 10.0 * (t - 5.0), 0.0)
    e, n = travelled * math.cos(0.4), travelled * math.sin(0.4)
    for k, (de, dn) in zip((12, 40, 77), ((-9.0, 3.0), (2.0, -11.0), (-8.0, -8.0)), strict=True):
        e[k] += de
        n[k] += dn
    cols = {"t": t, "v_rl": speed, "v_rr": speed, "gnss_e": e, "gnss_n": n}
    course, t_a, _ = gnss.course_from_fixes(drive_from_columns(cols, {}))
    assert course == pytest.approx(0.4, abs=0.01)
    assert t_a >= 4.9


def _fast_fixes(noise_m: float, seed: int, jump_share: float) -> tuple[np.ndarray, ...]:
    """20 Hz fixes along a 1 g turn of R 50 m (22 m/s), white noise ``noise_m`` per axis and
    8 m multipath jumps (per axis, as the simulator's) on a share ``jump_share`` of the epochs."""
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, 60.0, 0.05)
    heading = 22.0 / 50.0 * t
    e = 50.0 * np.sin(heading) + rng.normal(0, noise_m, t.size)
    n = 50.0 * (1.0 - np.cos(heading)) + rng.normal(0, noise_m, t.size)
    jumps = rng.random(t.size) < jump_share
    e[jumps] += rng.normal(0, 8.0, jumps.sum())
    n[jumps] += rng.normal(0, 8.0, jumps.sum())
    return t, e, n, jumps


def test_jumped_fixes_finds_multipath_jumps_and_spares_a_smooth_turn_at_one_g() -> None:
    # jumps of 8 m per axis against 0.45 m white noise: the misses of a jump are > 6 robust
    # scales unless the jump happens to be small (|N(0, 8)^2| < ~3 m: under 5 % of them)
    t, e, n, jumps = _fast_fixes(0.45, seed=3, jump_share=0.05)
    flagged = gnss.jumped_fixes(t, e, n)
    assert flagged[jumps].mean() >= 0.9
    assert flagged[~jumps].mean() <= 0.005
    # a smooth receiver (1 cm scatter) in a 1 g turn: the curvature inside the window (under
    # 0.2 m) stays below the 0.5 m floor, nothing is flagged
    t, e, n, _ = _fast_fixes(0.01, seed=4, jump_share=0.0)
    assert not gnss.jumped_fixes(t, e, n).any()
    # a slow receiver has no neighbours close enough in time: nothing is judged
    assert not gnss.jumped_fixes(t[::20], e[::20], n[::20]).any()


def test_positions_only_course_keeps_no_multipath_sample_at_pull_off() -> None:
    # The simulator's nonlinear drive (demo: a stop and pull-off) with 20 Hz positions, no
    # Doppler and multipath on 5 % of the epochs.  Before the jump check and the speed agreement
    # with the wheels, 7-8 % of the samples were beyond 5 sigma (30-50 % of those under
    # 8 m/s, up to 165 deg off): multipath adds speed, which shrank their sigma under the gate.
    from sideslip.signals import vehicle_speed
    from sideslip.simulate import SensorConfig, simulate
    from sideslip.simulate.run import _lookup

    receiver = {"gnss_rate_hz": 20.0, "gnss_doppler": False, "gnss_multipath_prob": 0.05}
    cfg = SensorConfig().with_overrides(_lookup("demo").sensor_overrides).with_overrides(receiver)
    drive = simulate("demo", seed=0, config=cfg)
    cs = gnss.course_samples(drive, vehicle_speed(drive), 3.0)
    truth = (drive["ref_yaw"] + drive["ref_beta"])[cs.rows]
    z = np.abs(wrap_angle(cs.course - truth)) / cs.sigma
    assert cs.rows.size > 1000
    assert np.mean(z > 5.0) < 0.002
    assert np.mean(z > 2.0) < 0.05  # no heavier tail than a normal's (the sigma is cautious)
