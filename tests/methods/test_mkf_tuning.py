"""Process noise of the MKF identified from the drive (sideslip.methods.mkf_tuning).

Truth: the simulator's nonlinear vehicle (Magic Formula tyres, roll) with a steering sensor of
known white noise, which the MKF's steering-input density (seed 001 eq 1, the noise w_delta
through B) describes: white noise of 1-sigma s per sample at 50 Hz held between samples has the
density s^2 / 50 Hz (rad^2 s).  Nothing here is the filter's own model.
"""

from __future__ import annotations

import functools
import math

import numpy as np
import pytest

from sideslip.methods.mkf import MkfSettings
from sideslip.methods.mkf_tuning import BETA_GRID, STEER_YAW_GRID, neg2_log_likelihood
from sideslip.methods.registry import run_method
from sideslip.models.mkf_model import MkfNoise
from sideslip.simulate import simulate
from sideslip.simulate.sensors import SensorConfig
from sideslip.vehicle import load_vehicle

STEER_RATE_HZ = SensorConfig().steer_rate_hz


@functools.cache
def _drive(steer_noise_deg: float):  # type: ignore[no-untyped-def]
    cfg = SensorConfig(steer_noise_std=math.radians(steer_noise_deg))
    d = simulate("step_steer", seed=1, config=cfg)
    return d, load_vehicle(d.meta["vehicle"])


@pytest.mark.parametrize("steer_noise_deg", [0.5, 2.0])
def test_auto_picks_the_steering_noise_density_of_the_drive(steer_noise_deg: float) -> None:
    """The identified steering density lies within the grid's half-step (a factor sqrt(10):
    the grid is spaced by decades, so the nearest grid value is never further than that from
    the truth) of the sensor's true density; the truth is 0.056x and 0.89x the typical value,
    so the two drives must pick different factors."""
    d, veh = _drive(steer_noise_deg)
    est = run_method("mkf", d, veh)
    noise = est.params["noise"]
    true_psd = math.radians(steer_noise_deg) ** 2 / STEER_RATE_HZ
    picked = noise["steer_psd_rad2_s"]
    assert true_psd / math.sqrt(10.0) <= picked <= true_psd * math.sqrt(10.0)
    ident = noise["process_noise_identification"]
    assert noise["process_noise_source"].startswith("drive")
    assert ident["steer_yaw_factor"] in STEER_YAW_GRID
    assert ident["beta_factor"] in BETA_GRID
    # the criterion's scores are in the params, and the choice is their minimum
    scores = ident["gyro_neg2_log_likelihood_by_factor"]
    assert min(scores, key=scores.get) == f"{ident['steer_yaw_factor']:g}"


def test_quiet_steering_sensor_gets_a_smaller_density_than_a_noisy_one() -> None:
    quiet = run_method("mkf", *_drive(0.01)).params["noise"]["steer_psd_rad2_s"]
    noisy = run_method("mkf", *_drive(2.0)).params["noise"]["steer_psd_rad2_s"]
    assert quiet < 0.1 * noisy


def test_paper_preset_and_explicit_values_are_not_tuned() -> None:
    d, veh = _drive(0.5)
    paper = run_method("mkf", d, veh, {"preset": "paper"}).params["noise"]
    typ = MkfNoise()
    assert paper["process_noise_identification"] is None
    assert paper["steer_psd_rad2_s"] == pytest.approx(typ.steer_psd)
    assert paper["gyro_sigma_100hz_rad_s"] == pytest.approx(math.radians(0.3))  # Table I
    # an explicit sideslip density is used as given; the steering/yaw group is still tuned
    fixed = run_method("mkf", d, veh, MkfSettings(beta_psd_rad2_per_s=1e-6)).params["noise"]
    assert fixed["beta_psd_rad2_per_s"] == pytest.approx(1e-6)
    assert fixed["process_noise_identification"]["beta_factor"] == 1.0
    assert fixed["process_noise_identification"]["course_neg2_log_likelihood_by_factor"] == {}


def test_explicit_steering_and_yaw_densities_override_the_identification() -> None:
    d, veh = _drive(0.5)
    est = run_method("mkf", d, veh, {"steer_psd_rad2_s": 2e-6, "yaw_accel_psd_rad2_s3": 1e-5})
    noise = est.params["noise"]
    assert noise["steer_psd_rad2_s"] == pytest.approx(2e-6)
    assert noise["yaw_accel_psd_rad2_s3"] == pytest.approx(1e-5)
    assert noise["process_noise_identification"]["steer_yaw_factor"] == 1.0


def test_neg2_log_likelihood_of_unit_gaussian_innovations() -> None:
    """Analytic case: N(0, S) innovations give E[ln S + nu^2/S] = ln S + 1 per update; NaN
    rows are not updates."""
    rng = np.random.default_rng(0)
    s = np.full(20000, 4.0)
    nu = rng.normal(0.0, 2.0, s.size)
    nu[::10] = np.nan
    total, n = neg2_log_likelihood(nu, s)
    assert n == 18000
    # the mean of nu^2/S over 18000 draws is 1 +- 0.011 (sd sqrt(2/n)); 0.05 is > 4 sd
    assert total / n == pytest.approx(math.log(4.0) + 1.0, abs=0.05)
