"""A late GNSS Doppler (sideslip.doppler_timing): the choice of the latency from the tyre-free
fit, the epochs moved to the receiver's time, and the paper methods run on that time."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sideslip.doppler_timing import choose_doppler_latency, drive_on_receiver_time, shift_gnss
from sideslip.evaluate import metrics
from sideslip.gnss_latency import LatencyEstimate
from sideslip.methods.registry import get_method, run_method, uses_gnss
from sideslip.vehicle import load_vehicle
from tests.conftest import sim_drive
from tests.test_gnss_latency import doppler_drive


def fit(latency_s: float, sigma_s: float) -> LatencyEstimate:
    return LatencyEstimate(latency_s, sigma_s, 1.0, 500)


@pytest.mark.parametrize(
    ("found", "used", "sigma", "note"),
    [
        ((0.2, 0.04), 0.2, math.hypot(0.04, 0.01), "each GNSS epoch"),  # a few turns decide it
        ((0.1, 0.04), 0.0, 0.1 * 0.05**2 / (0.05**2 + 0.04**2), "not applied: the drive does"),
        ((0.9, 0.01), 0.5, math.hypot(0.01, 0.01), "each GNSS epoch"),  # held to 0.5 s
        ((0.3, 0.06), 0.0, None, "not applied: the drive does"),  # too loose to move epochs
    ],
)
def test_the_latency_is_chosen_where_the_fit_decides_it(found, used, sigma, note) -> None:
    timing = choose_doppler_latency(fit(*found), 0.05)
    assert timing.latency_s == pytest.approx(used)
    if sigma is not None and used == 0.0:
        # not applied: the rms about 0 of the fit with the prior, at least its posterior mean
        assert timing.sigma_s >= sigma
    elif sigma is not None:
        assert timing.sigma_s == pytest.approx(sigma)
    assert timing.note.startswith(note)


def test_epochs_move_to_their_stamp_less_the_latency() -> None:
    drive = sim_drive("demo")
    moved = shift_gnss(drive, 0.1)
    rows = np.flatnonzero(np.isfinite(drive["gnss_ve"]))
    new_rows = np.flatnonzero(np.isfinite(moved["gnss_ve"]))
    # the first epoch (at the drive's first row) falls before the drive and is dropped
    assert new_rows.size == rows.size - int(drive.t[rows[0]] - 0.1 < drive.t[0] - 0.005)
    np.testing.assert_allclose(moved.t[new_rows], drive.t[rows[-new_rows.size :]] - 0.1, atol=0.006)
    np.testing.assert_array_equal(moved["gnss_ve"][new_rows], drive["gnss_ve"][rows[-new_rows.size :]])
    np.testing.assert_array_equal(moved["gnss_e"][new_rows], drive["gnss_e"][rows[-new_rows.size :]])
    np.testing.assert_array_equal(moved["wz"], drive["wz"])  # nothing else moves
    assert shift_gnss(drive, 0.0) is drive


def test_only_the_gnss_methods_are_handed_the_receivers_time() -> None:
    assert uses_gnss(get_method("doppler_slip")) and uses_gnss(get_method("kkf"))
    assert uses_gnss(get_method("ekf_wss_sas"))
    assert not uses_gnss(get_method("fused"))  # it times the receiver itself
    assert not uses_gnss(get_method("fg_batch"))


def test_an_on_time_doppler_stays_where_it_is() -> None:
    """On time (the comparison's drives), nothing moves: demo reads +0.000 +- 0.010 s."""
    drive = sim_drive("demo")
    moved, timing = drive_on_receiver_time(drive, load_vehicle(drive.meta["vehicle"]))
    assert timing is not None and timing.latency_s == 0.0
    assert moved is drive


@pytest.mark.parametrize(("method", "bound_deg"), [("doppler_slip", 0.5), ("kkf", 0.5)])
def test_paper_methods_run_on_the_receivers_time(method, bound_deg) -> None:
    """The race lap with every GNSS epoch 200 ms late: seed 000's slip (doppler_slip) read r x
    0.2 s as slip in every corner, 2.60 deg beta RMSE (0.226 on time), and seed 001's kkf
    2.65 deg on a 5 Hz receiver; the drive decides the latency (+0.202 +- 0.006 s), and
    run_method hands them the epochs that much earlier: measured 0.23 / 0.27 deg.  Bound
    halfway in log between on time and late."""
    drive = doppler_drive("race_lap", 0.2)
    vehicle = load_vehicle(drive.meta["vehicle"])
    est = run_method(method, drive, vehicle)
    assert est.params["gnss_doppler_latency_applied_s"] == pytest.approx(0.2, abs=0.02)
    assert metrics(drive, est.series)["beta_rmse_deg"] < bound_deg


def test_the_applied_latencys_sigma_reaches_the_paper_methods_beta_std() -> None:
    """Epochs moved by a latency known to sigma: a residual tau lags the course by r tau, so
    |r| sigma joins the method's own beta_std (cr_limit_ramp with a 5 Hz Doppler 200 ms late:
    doppler_slip 75 -> 89 % inside 2 sigma, measured 2026-12-07)."""
    drive = doppler_drive("race_lap", 0.2)
    vehicle = load_vehicle(drive.meta["vehicle"])
    est = run_method("doppler_slip", drive, vehicle)
    moved, timing = drive_on_receiver_time(drive, vehicle)
    assert timing is not None and timing.latency_s > 0.0 and timing.sigma_s > 0.005
    method = get_method("doppler_slip")
    own = method.func(moved, vehicle, method.default_settings())
    expected = np.hypot(own["beta_std"], np.abs(own["r"]) * timing.sigma_s)
    np.testing.assert_allclose(est["beta_std"], expected, rtol=1e-9)


@pytest.mark.parametrize(
    ("found", "early"),
    [((-0.048, 0.006), True), ((-0.02, 0.006), False), ((-0.1, 0.03), False), ((0.003, 0.006), False)],
)
def test_a_decisive_fit_that_reads_the_doppler_early_is_flagged(found, early) -> None:
    """Early by more than 3 sigma (the sigma with its 10 ms floor) of a decisive fit: not
    applied, but flagged, with the early reading as the sigma; a loose fit or one within its
    errors is not."""
    timing = choose_doppler_latency(fit(*found), 0.05)
    assert timing.latency_s == 0.0
    assert timing.early is early
    assert ("early against the gyro" in timing.note) is early
    if early:
        assert timing.sigma_s == pytest.approx(abs(found[0]))


def test_an_imu_stamped_late_is_moved_back_before_the_receiver_is_timed() -> None:
    """The race lap with every IMU sample 50 ms late against the rest of the table: the
    course-rate fit reads the Doppler 0.048 +- 0.006 s early (measured).  Receivers are not
    early: the IMU is moved back by that (sideslip.imu_timing), and the receiver timed on the
    moved drive is on time.  Measured 2026-12-07: doppler_slip 0.725 deg unmoved, 0.229 moved
    (0.226 with the IMU on time), 97 % inside 2 sigma; kkf 0.748 -> 0.180, 100 %."""
    from dataclasses import replace

    from tests.methods.test_fused import two_sigma_share

    drive = sim_drive("race_lap")
    k = round(0.05 / drive.dt_median)
    data = dict(drive.data)
    for name in ("ax", "ay", "az", "wx", "wy", "wz"):
        col = np.full(len(drive), np.nan)
        col[k:] = np.asarray(data[name], dtype=float)[:-k]
        data[name] = col
    late = replace(drive, data=data)
    vehicle = load_vehicle(drive.meta["vehicle"])
    for method, bound in (("doppler_slip", 0.4), ("kkf", 0.35)):
        est = run_method(method, late, vehicle)
        assert est.params["imu_lag_applied_s"] == pytest.approx(0.05, abs=0.015)
        assert est.params["gnss_doppler_latency_applied_s"] == 0.0
        assert "early" not in est.params["gnss_doppler_latency_applied_note"]
        assert metrics(late, est.series)["beta_rmse_deg"] < bound
        assert two_sigma_share(late, est) >= 0.95
