"""The receiver latency from the fixes' speed against the wheels (sideslip.gnss_latency),
graded on the simulator's receiver, whose latency is known (fixes report the truth that long
before their stamp) and whose tyres, slip and speed control are not the estimator's model."""

from __future__ import annotations

import functools

import pytest

from sideslip.gnss_latency import LatencyEstimate, identify_doppler_latency, identify_latency
from sideslip.simulate import SensorConfig, simulate
from sideslip.simulate.run import _lookup
from tests.conftest import sim_drive


@functools.lru_cache(maxsize=8)
def positions_drive(name: str, latency_s: float, lever_x: float = 0.0, lever_y: float = 0.0) -> object:
    """``name`` with a 20 Hz receiver without Doppler, ``latency_s`` late, its antenna
    ``lever_x`` ahead of and ``lever_y`` left of where the vehicle file says."""
    receiver = {"gnss_rate_hz": 20.0, "gnss_doppler": False, "gnss_latency_s": latency_s,
                "gnss_lever_offset_x": lever_x, "gnss_lever_offset_y": lever_y}  # fmt: skip
    config = SensorConfig().with_overrides(_lookup(name).sensor_overrides).with_overrides(receiver)
    return simulate(name, seed=0, config=config)


@pytest.mark.parametrize("latency_s", [0.05, 0.15])
def test_latency_is_found_where_the_car_speeds_up_and_slows_down(latency_s: float) -> None:
    """urban_course (stops and starts): measured 0.061 / 0.162 s with a 1-sigma of 0.04 s for
    the true 0.05 / 0.15 s; the bound asks for 2.5 sigma, and the wheel scale within 1 %."""
    found = identify_latency(positions_drive("urban_course", latency_s))
    assert found is not None
    assert abs(found.latency_s - latency_s) < 2.5 * found.sigma_s
    assert found.sigma_s < 0.06
    assert found.wheel_scale == pytest.approx(1.0, abs=0.01)


def test_a_constant_speed_drive_does_not_inform_the_latency() -> None:
    """two_turns_gyro_sf (72 km/h throughout): the fixes' speed never leads or lags the wheels,
    so the estimate's sigma is seconds and, with the prior N(0, 0.1 s), nothing moves."""
    found = identify_latency(positions_drive("two_turns_gyro_sf", 0.15))
    assert found is not None and found.sigma_s > 1.0
    assert abs(found.posterior_mean(0.1)) < 0.001
    assert found.posterior_sigma(0.1) == pytest.approx(0.1, rel=0.01)


def test_no_estimate_without_fast_fixes() -> None:
    assert identify_latency(sim_drive("demo", 0)) is None  # Doppler: its epochs are not timed here
    assert identify_latency(positions_drive("suburban_outages", 0.05).slice(0, 50)) is None


def test_posterior_combines_the_estimate_with_the_prior() -> None:
    est = LatencyEstimate(latency_s=0.2, sigma_s=0.1, wheel_scale=1.0, fixes=500)
    assert est.posterior_mean(0.1) == pytest.approx(0.1)  # equal weights
    assert est.posterior_sigma(0.1) == pytest.approx(0.1 / 2**0.5)
    assert LatencyEstimate(2.0, 0.01, 1.0, 500).posterior_mean(0.1) == 0.5  # held in range


@pytest.mark.parametrize("lever_y", [0.0, 0.5])
def test_lateral_lever_arm_is_found_in_turns(lever_y: float) -> None:
    """urban_course's antenna 0.5 m left of (or on) the centreline, fixes 50 ms late with the
    antenna also 0.5 m ahead (the longitudinal offset must not leak in): measured +0.512 /
    +0.015 m with a 1-sigma of 0.12 m; the bound asks for 2.5 sigma and a sigma that informs
    against the 0.5 m prior."""
    found = identify_latency(positions_drive("urban_course", 0.05, 0.5, lever_y))
    assert found is not None
    assert found.lever_y_sigma_m < 0.2
    assert abs(found.lever_y_m - lever_y) < 2.5 * found.lever_y_sigma_m


def test_lever_posterior_keeps_the_prior_where_the_drive_did_not_turn() -> None:
    est = LatencyEstimate(0.0, 0.01, 1.0, 500, lever_y_m=0.4, lever_y_sigma_m=0.5)
    mean, sigma = est.lever_y_posterior(prior_m=0.0, prior_sigma_m=0.5)
    assert mean == pytest.approx(0.2)  # equal weights
    assert sigma == pytest.approx(0.5 / 2**0.5)
    straight = LatencyEstimate(0.0, 0.01, 1.0, 500)  # no turn: sigma inf
    assert straight.lever_y_posterior(prior_m=-0.3, prior_sigma_m=0.5) == (-0.3, 0.5)


@functools.lru_cache(maxsize=4)
def doppler_drive(name: str, latency_s: float) -> object:
    """``name`` with its own receiver (10 Hz fixes and Doppler), every epoch ``latency_s`` late."""
    config = SensorConfig().with_overrides(_lookup(name).sensor_overrides)
    return simulate(name, seed=0, config=config.with_overrides({"gnss_latency_s": latency_s}))


@pytest.mark.parametrize("latency_s", [0.0, 0.1])
def test_doppler_latency_is_found_from_its_speed_against_the_wheels(latency_s: float) -> None:
    """demo (a stop, speed changes): measured +0.000 / +0.101 s with a 1-sigma of 0.010 s for
    the true 0 / 0.1 s; the bound asks for 2.5 sigma and a sigma that decides (under 15 ms,
    fused's threshold for using it)."""
    found = identify_doppler_latency(doppler_drive("demo", latency_s))
    assert found is not None
    assert found.sigma_s < 0.015
    assert abs(found.latency_s - latency_s) < 2.5 * found.sigma_s


def test_one_turn_at_constant_speed_informs_the_doppler_latency_but_does_not_decide_it() -> None:
    """step_steer at 80 km/h: the Doppler speed never leads or lags the wheels (speed fit: a
    sigma of hundreds of seconds); its one turn gives the course-rate fit +0.098 +- 0.066 s
    for the true 0.1 s.  Both are kept, the combination is the course rate's, and its sigma
    stays above fused's 15 ms threshold for moving the epochs."""
    found = identify_doppler_latency(doppler_drive("step_steer", 0.1))
    assert found is not None
    assert found.speed_sigma_s > 1.0
    assert found.latency_s == pytest.approx(found.lateral_s, abs=1e-4)
    assert 0.015 < found.sigma_s < 0.15
    assert abs(found.latency_s - 0.1) < 2.5 * found.sigma_s


@pytest.mark.parametrize("latency_s", [0.0, 0.1])
def test_a_slalom_at_constant_speed_decides_the_doppler_latency_by_its_turns(latency_s: float) -> None:
    """slalom_low_mu (one speed, 0.5 Hz steering): the speed fit cannot tell (sigma of hours),
    the course rate against the lateral accelerometer decides (measured +0.002 / +0.103 +-
    0.014-0.016 s for the true 0 / 0.1 s); 2.5 sigma and fused's 15 ms threshold (20 ms here:
    the threshold applies to the combination, which has the same sigma)."""
    found = identify_doppler_latency(doppler_drive("slalom_low_mu", latency_s))
    assert found is not None
    assert found.speed_sigma_s > 1.0
    assert found.sigma_s < 0.02
    assert abs(found.latency_s - latency_s) < 2.5 * found.sigma_s


def test_contradicting_doppler_fits_widen_the_combined_sigma(monkeypatch) -> None:
    """Speed fit 0.00 +- 0.01 s and course-rate fit 0.10 +- 0.01 s: the inverse-variance mean
    0.05 s with sigma 0.01 / sqrt(2), times the Birge ratio sqrt(chi^2) = 0.1 / (0.01 sqrt(2)),
    i.e. 0.05 s: the two fits together no longer decide the latency."""
    from sideslip import doppler_latency_lateral, gnss_latency

    monkeypatch.setattr(gnss_latency, "_doppler_latency_from_speed", lambda drive: LatencyEstimate(0.0, 0.01, 1.0, 500))
    monkeypatch.setattr(doppler_latency_lateral, "lateral_doppler_latency", lambda drive, *geometry: (0.1, 0.01, 1.0))
    found = identify_doppler_latency(doppler_drive("demo", 0.0))
    assert found is not None
    assert found.latency_s == pytest.approx(0.05)
    assert found.sigma_s == pytest.approx(0.05)
    assert (found.speed_s, found.lateral_s) == (0.0, 0.1)


def test_no_doppler_latency_without_doppler() -> None:
    assert identify_doppler_latency(positions_drive("suburban_outages", 0.05)) is None
