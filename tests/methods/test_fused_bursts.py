"""The smoother's second look at the Doppler (sideslip.methods.fused_bursts)."""

from __future__ import annotations

import numpy as np
import pytest

from sideslip.evaluate import SPEED_GATE, metrics
from sideslip.frames import wrap_angle
from sideslip.methods.fused_bursts import RAYLEIGH_MEDIAN, burst_epochs, residual_scale
from sideslip.methods.registry import run_method
from sideslip.vehicle import load_vehicle
from tests.conftest import sim_drive


def _distances(rng: np.random.Generator, sigma: float, n: int) -> np.ndarray:
    """Distances of two-dimensional Gaussian errors with per-axis ``sigma``."""
    return np.hypot(rng.normal(0.0, sigma, n), rng.normal(0.0, sigma, n))


def test_the_residual_scale_is_the_per_axis_sigma_of_the_drives_errors():
    """4000 two-dimensional Gaussian errors of 0.07 m/s per axis: the median distance over
    sqrt(2 ln 2) is the per-axis sigma (the median's standard error at n = 4000 is about
    2 %; 5 % allowed); a receiver quoting more than that keeps its own sigma."""
    rng = np.random.default_rng(3)
    res = _distances(rng, 0.07, 4000)
    scale = residual_scale(res, np.full(res.size, 0.02))
    assert scale[0] == pytest.approx(0.07, rel=0.05)
    assert np.all(residual_scale(res, np.full(res.size, 0.2)) == 0.2)
    assert RAYLEIGH_MEDIAN == pytest.approx(1.1774, abs=1e-4)


def test_a_run_beyond_the_drives_scale_is_a_burst_with_its_edges_a_lone_outlier_is_not():
    """300 epochs of 0.05 m/s per axis; epochs 100-109 carry a burst of 0.5 m/s, epoch 200 a
    lone 0.6 m/s spike, and every tenth row has no Doppler (NaN: no epoch, no break in a
    run).  The burst and the epoch on either side of it are flagged; the spike is not."""
    rng = np.random.default_rng(5)
    res = np.minimum(_distances(rng, 0.05, 300), 0.12)  # the clean epochs: below 3.5 x 0.05
    res[100:110] = 0.5
    res[200] = 0.6
    res[::10] = np.nan
    flagged = burst_epochs(res, np.full(res.size, 0.05), gate=3.5)
    expected = np.zeros(res.size, dtype=bool)
    expected[[99, *range(101, 110), 111]] = True  # row 100 and 110 are NaN: the edges skip them
    np.testing.assert_array_equal(flagged, expected)
    assert not flagged[np.isnan(res)].any()


def test_a_drive_wrong_everywhere_reads_no_burst():
    """A tyre model or file wrong throughout raises every residual (here 0.3 m/s per axis
    where the receiver quotes 0.05): against the receiver's sigma half the epochs would be
    beyond the gate, in runs; against the drive's own scale none is a burst."""
    rng = np.random.default_rng(7)
    res = _distances(rng, 0.3, 2000)
    sigma = np.full(res.size, 0.05)
    assert np.mean(res > 3.5 * sigma) > 0.5  # what a fixed scale would take for bursts
    assert not burst_epochs(res, sigma, gate=3.5).any()


@pytest.mark.commonroad
def test_a_multipath_burst_at_the_limit_is_found_on_the_smoothed_track():
    """cr_limit_ramp seed 0 (CommonRoad's multi-body BMW on mu 0.6 ramping into front-axle
    saturation, GNSS with multipath bursts), right file.  The forward check admits the
    middle of the longer bursts; the smoothed track shows them.  Measured: beta RMSE 0.109
    deg without the second look, 0.061 with it, 100 % inside 2 sigma both.  Bounds: the
    measured value plus 40 % (under the 0.109 without), issue 15's 2-sigma share, the look
    must matter (off at least 1.5x worse) and the params count the epochs it took again."""
    pytest.importorskip("vehiclemodels", reason="needs the optional commonroad extra")
    drive = sim_drive("cr_limit_ramp", 0)
    vehicle = load_vehicle(drive.meta["vehicle"])
    est = run_method("fused", drive, vehicle)
    rmse = metrics(drive, est.series)["beta_rmse_deg"]
    assert rmse < 0.085
    gate = drive["ref_vx"] > SPEED_GATE
    err = np.abs(wrap_angle(est["beta"] - drive["ref_beta"]))[gate]
    assert float(np.mean(err < 2 * est["beta_std"][gate])) >= 0.90
    assert est.params["gnss_doppler_burst_epochs"] > 0
    assert "gnss_doppler_bursts" in est.params["assumed"]
    off = run_method("fused", drive, vehicle, settings={"doppler_burst_check": False})
    assert metrics(drive, off.series)["beta_rmse_deg"] > 1.5 * rmse
