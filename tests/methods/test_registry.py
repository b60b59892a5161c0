"""The shared method pipeline (:func:`sideslip.methods.registry.run_method`): memory per row of
the heaviest methods, and results on a compact drive."""

from __future__ import annotations

import tracemalloc

import numpy as np
import pytest

from sideslip.bench import tiled_drive
from sideslip.methods.registry import run_method
from sideslip.vehicle import load_vehicle
from tests.conftest import sim_drive

# Issue #17: a 24 h, 100 Hz drive (8.64 M rows) through every method in <= 4 GB of process.
# Measured at 24 h (benchmarks/scaling.py), the process before a method runs (interpreter with
# numpy/numba/pandas, and the compact drive: t and GNSS positions float64, 17 sensor channels
# float32, 100 B/row) is 1.19 GB, which leaves (4.0 - 1.19) GB / 8.64 M rows = 340 B/row for
# the method.  What grows with the drive is the method's peak heap (tracemalloc sees numpy's
# and numba's arrays) per extra row: measured between two lengths so that the fixed cost of a
# run (compiled code, chunk buffers) cancels.  Before the chunked observer matrices, the
# compact EKF storage, the streamed input health and the graph freed after assembly these
# methods took 400-560 B/row (mkf 379, mkf_adaptive 392, kkf 302 before the MKF/KKF outputs
# were formed in place).
BYTES_PER_ROW_BUDGET = 340.0
HEAVY = ("obs_modified", "obs_modified_nocomp", "obs_bicycle", "ekf_wss_sas", "ekf_wss_sas_imu",
         "doppler_slip", "doppler_slip_noroll", "kf_linear", "fg_batch", "fg_lag",
         "mkf", "mkf_adaptive", "kkf")  # fmt: skip
ROWS = (60_000, 180_000)


@pytest.fixture(scope="module")
def long_drive():
    base = sim_drive("demo")
    hours = ROWS[1] * base.dt_median / 3600.0
    return tiled_drive(base, hours).compact(), load_vehicle(base.meta["vehicle"])


def _peak_bytes(name, drive, vehicle):
    tracemalloc.start()
    try:
        base = tracemalloc.get_traced_memory()[0]
        est = run_method(name, drive, vehicle)
        peak = tracemalloc.get_traced_memory()[1] - base
    finally:
        tracemalloc.stop()
    assert np.isfinite(est["beta"]).all()
    return peak


@pytest.mark.parametrize("name", HEAVY)
def test_heavy_method_peak_memory_per_row_fits_a_day_long_drive_in_4_gb(long_drive, name):
    drive, vehicle = long_drive
    run_method(name, drive.slice(0, 6000), vehicle)  # compile and warm caches first
    short, long = (_peak_bytes(name, drive.slice(0, n), vehicle) for n in ROWS)
    per_row = (long - short) / (ROWS[1] - ROWS[0])
    assert 0 < per_row < BYTES_PER_ROW_BUDGET, f"{name}: {per_row:.0f} B/row"


@pytest.mark.parametrize("name", ["obs_modified", "ekf_wss_sas_imu", "fg_batch", "doppler_slip",
                                  "kinematic_integration", "obs_bicycle"])
def test_compact_drive_changes_results_by_input_rounding_only(name):
    drive = sim_drive("demo")
    vehicle = load_vehicle(drive.meta["vehicle"])
    full = run_method(name, drive, vehicle)
    small = run_method(name, drive.compact(), vehicle)
    # float32 storage rounds each sensor sample by at most 6e-8 of its value (e.g. 1e-8 rad/s
    # on a 0.2 rad/s yaw rate, 6e-7 m/s at 10 m/s): far below the sensors' own noise, so
    # beta moves by well under a micro-radian... allow 1e-5 rad (0.0006 deg), 1000x below
    # the 0.1-0.5 deg accuracy the methods reach, for gains of stiff filters and gates.
    diff = np.abs(full["beta"] - small["beta"])
    assert diff.max() < 1e-5, f"{name}: beta moved by {diff.max():.2e} rad"
    assert full.series.keys() == small.series.keys()
