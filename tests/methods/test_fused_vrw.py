"""The velocity random walk's direct search (sideslip.methods.fused_vrw) on analytic
likelihoods, and on a simulated drive against its truth."""

from __future__ import annotations

import math

import pytest

from sideslip.drive import drive_from_columns
from sideslip.evaluate import metrics
from sideslip.methods.fused import fuse
from sideslip.methods.fused_settings import FusedSettings
from sideslip.methods.fused_vrw import search_accel_vrw, search_noise_scale
from sideslip.vehicle import load_vehicle
from tests.conftest import sim_drive
from tests.methods.test_fused import two_sigma_share

DOPPLER = ("gnss_ve", "gnss_vn", "gnss_vu", "gnss_vel_std")


def _bowl(best: float):
    """-2 log L of a one-parameter Gaussian model: quadratic in log2(vrw) around ``best``,
    and the calls it received (each a list of values)."""
    calls: list[list[float]] = []

    def f(values):
        calls.append(list(values))
        return [40.0 * (math.log2(v) - math.log2(best)) ** 2 for v in values]

    return f, calls


@pytest.mark.parametrize(
    ("best", "expected"),
    [
        (0.1, 0.1),  # the prior is right: it stays
        (0.026, 0.025),  # two halvings down
        (0.006, 0.00625),  # four halvings, the grid point nearest in log
        (0.33, 0.4),  # up: a rougher drive than the prior (0.4 nearer 0.33 than 0.2 in log)
        (1e-5, 0.00625),  # the min factor 1/16 bounds the walk down
        (50.0, 0.4),  # the max factor 4 bounds the walk up
    ],
)
def test_the_search_finds_the_grid_point_of_the_likelihoods_maximum(best, expected):
    f, calls = _bowl(best)
    choice = search_accel_vrw(f, prior=0.1, floor=0.0)
    assert choice.value == pytest.approx(expected)
    assert all(len(c) <= 2 for c in calls)  # two at a time (two threads)
    assert dict(choice.tried)[choice.value] == 0.0
    assert min(d for _, d in choice.tried) == 0.0
    assert "m/s/sqrt(s) (prior 0.1)" in choice.note()


def test_the_accelerometers_own_noise_floors_the_search():
    """A drive whose accelerometer alone has 0.02 m/s/sqrt(s) cannot have less process noise,
    whatever its innovations say: no candidate below the floor is tried."""
    f, calls = _bowl(0.001)
    choice = search_accel_vrw(f, prior=0.1, floor=0.02)
    assert choice.value == pytest.approx(0.025)
    assert min(v for c in calls for v in c) >= 0.02


def test_a_failed_candidate_is_not_chosen_and_ties_keep_the_prior():
    """A candidate whose pass gives a non-finite likelihood is never the choice; a flat
    likelihood (no evidence) keeps the prior."""
    choice = search_accel_vrw(lambda vs: [math.nan if v < 0.1 else 5.0 for v in vs], 0.1, 0.0)
    assert choice.value == pytest.approx(0.1)
    flat = search_accel_vrw(lambda vs: [1.0 for _ in vs], 0.1, 0.0)
    assert flat.value == pytest.approx(0.1)


def test_a_bad_prior_is_one_clear_error():
    with pytest.raises(ValueError, match=r"prior velocity random walk must be positive and finite, got 0.0"):
        search_accel_vrw(lambda vs: [0.0 for _ in vs], 0.0, 0.0)
    with pytest.raises(ValueError, match=r"prior noise density must be positive and finite, got inf"):
        search_noise_scale(lambda vs: [0.0 for _ in vs], math.inf, 0.0)
    with pytest.raises(ValueError, match=r"FusedSettings.cy_psd_min_factor = 3.0: expected <= 1"):
        FusedSettings(cy_psd_min_factor=3.0)
    with pytest.raises(ValueError, match=r"FusedSettings.accel_vrw_min_factor = 2.0: expected <= 1"):
        FusedSettings(accel_vrw_min_factor=2.0)
    with pytest.raises(ValueError, match=r"FusedSettings.accel_vrw_max_factor = 0.5: expected >= 1"):
        FusedSettings(accel_vrw_max_factor=0.5)


def test_the_drive_identifies_a_cleaner_kinematics_than_the_prior_and_beta_gains():
    """urban_highway (nonlinear tyres, roll, crossfall, a MEMS IMU with 0.05 m/s^2 of white
    noise, 10 Hz Doppler): the Doppler innovations ask for a velocity random walk below the
    0.1 m/s/sqrt(s) prior (measured 0.025), and beta follows the truth better than with the
    prior (measured, seed 0: 0.034 -> 0.029 deg RMSE; the bound 0.95x asks for a real gain
    beyond run-to-run arithmetic, which is deterministic here) without leaving 2 sigma."""
    drive = sim_drive("urban_highway")
    v = load_vehicle(drive.meta["vehicle"])
    fixed = fuse(drive, v, smooth=True, settings=FusedSettings(identify_accel_vrw=False))
    found = fuse(drive, v, smooth=True)
    assert "accel_vrw" not in fixed.params["assumed"]
    note = found.params["assumed"]["accel_vrw"]
    vrw = float(note.split(" ")[0])
    assert 0.005 <= vrw <= 0.05, note
    rmse_fixed = metrics(drive, fixed.series)["beta_rmse_deg"]
    rmse_found = metrics(drive, found.series)["beta_rmse_deg"]
    assert rmse_found < 0.95 * rmse_fixed, (rmse_found, rmse_fixed)


def test_without_doppler_the_prior_stays():
    """Positions only, or no GNSS: nothing independent of the tyres measures the velocity,
    so the prior is kept and no note is written, in the smoother and the causal filter."""
    drive = sim_drive("step_steer")
    v = load_vehicle(drive.meta["vehicle"])
    cols = {"t": drive.t, **{k: c for k, c in drive.data.items() if k not in DOPPLER}}
    no_doppler = drive_from_columns(cols, dict(drive.meta))
    assert "accel_vrw" not in fuse(no_doppler, v, smooth=True).params["assumed"]
    assert "accel_vrw" not in fuse(no_doppler, v, smooth=False).params["assumed"]


def test_the_causal_filter_reads_its_noise_and_the_roll_gyros_bank_from_the_drive_too():
    """banked_turn (a 25 deg banked ramp, nonlinear tyres, 10 Hz Doppler): the causal filter
    with the velocity random walk and c_y's walk read from the drive and the roll gyro
    driving the bank (its bias the drive's mean roll rate) follows the truth far better than
    with c_y a free random walk at the priors (measured, seed 0: 0.095 -> 0.027 deg; bound
    0.5x, a gain far beyond the deterministic run's arithmetic), inside its 2 sigma."""
    drive = sim_drive("banked_turn")
    v = load_vehicle(drive.meta["vehicle"])
    prior = FusedSettings(identify_accel_vrw=False, roll_gyro_bank_with_doppler=False)
    before = fuse(drive, v, smooth=False, settings=prior)
    after = fuse(drive, v, smooth=False)
    assert "accel_vrw" in after.params["assumed"] and "cy_psd" in after.params["assumed"]
    rmse_before = metrics(drive, before.series)["beta_rmse_deg"]
    rmse_after = metrics(drive, after.series)["beta_rmse_deg"]
    assert rmse_after < 0.5 * rmse_before, (rmse_after, rmse_before)
    assert two_sigma_share(drive, after) >= 0.95


def test_the_roll_gyro_drives_the_bank_with_doppler_and_its_random_walk_is_read_from_the_drive():
    """step_steer (nonlinear tyres, body roll, 10 Hz Doppler): with c_y a free random walk the
    Doppler's noise wanders into v_y in the steady turn; with the roll gyro driving the bank
    the remaining random walk is read from the drive (measured: 0.05 of the 0.2 prior) and
    beta follows the truth better (measured, seed 0: 0.028 -> 0.019 deg; bound 0.85x, a gain
    well past arithmetic noise, which is zero here: the run is deterministic) while staying
    inside its 2 sigma.  A drive without the roll gyro keeps the random walk and its prior."""
    drive = sim_drive("step_steer")
    v = load_vehicle(drive.meta["vehicle"])
    free = fuse(drive, v, smooth=True, settings=FusedSettings(roll_gyro_bank_with_doppler=False))
    rolled = fuse(drive, v, smooth=True)
    assert "cy_psd" not in free.params["assumed"]
    note = rolled.params["assumed"]["cy_psd"]
    assert "m/s^2/sqrt(s) (prior 0.2)" in note
    assert float(note.split(" ")[0]) < 0.2, note
    rmse_free = metrics(drive, free.series)["beta_rmse_deg"]
    rmse_rolled = metrics(drive, rolled.series)["beta_rmse_deg"]
    assert rmse_rolled < 0.85 * rmse_free, (rmse_rolled, rmse_free)
    assert two_sigma_share(drive, rolled) >= 0.95
    cols = {"t": drive.t, **{k: c for k, c in drive.data.items() if k != "wx"}}
    no_roll_gyro = fuse(drive_from_columns(cols, dict(drive.meta)), v, smooth=True)
    assert "cy_psd" not in no_roll_gyro.params["assumed"]
    assert "accel_vrw" in no_roll_gyro.params["assumed"]
