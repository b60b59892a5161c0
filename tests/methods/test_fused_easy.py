"""fused on gentle drives with GNSS Doppler (issue 15 pt 4): the axle relations' noise is
identified from their innovations (the adaptive factor follows the NIS down as well as up,
bounded at FusedSettings.adapt_min), so the tyres, not the Doppler noise, set beta where the
brush model fits.  Before, fused sat at an error floor of 0.02-0.04 deg (demo 0.022, urban_highway
0.035) with axle NIS 0.04-0.05 (sigma ~4.5x too wide).  The deflation is an option
(``adapt_min = 0.25``): by default the factor stays >= 1, since on the real comma2k19 minute the
deflated sigma held 81 % of the errors inside 2 sigma (tests/io/test_realdata_check.py)."""

from __future__ import annotations

import functools

import numpy as np

from sideslip.drive import drive_from_columns
from sideslip.evaluate import SPEED_GATE, metrics
from sideslip.frames import wrap_angle
from sideslip.methods.registry import run_method
from sideslip.vehicle import load_vehicle
from tests.conftest import sim_drive


def _run(name: str, scenario: str, **settings: float):
    drive = sim_drive(scenario)
    est = run_method(name, drive, load_vehicle(drive.meta["vehicle"]), settings or None)
    return drive, est


DEMO_SEEDS = range(5)


@functools.cache
def _demo_rmse(name: str, **settings: float) -> float:
    """beta RMSE (deg) of a method, the mean over the demo drive's seeds 0-4: one seed's
    realisation moves a method by 30 % at this error level (fused with the trapezoidal rule:
    0.0143-0.0190 over the seeds, rectangle rule 0.0092-0.0253)."""
    errors = []
    for seed in DEMO_SEEDS:
        drive = sim_drive("demo", seed)
        est = run_method(name, drive, load_vehicle(drive.meta["vehicle"]), settings or None)
        errors.append(metrics(drive, est.series)["beta_rmse_deg"])
    return float(np.mean(errors))


def test_fused_is_within_ten_percent_of_doppler_slip_on_the_demo_drive():
    # issue 15's target (best or within 10 % of the best), over five seeds; measured
    # 2026-12-07: 0.0166 against doppler_slip's 0.0168 (rectangle rule 0.0179; seed 0 alone
    # was 0.0124 against 0.0125 before the trapezoidal rule, 0.0178 with it)
    assert _demo_rmse("fused", adapt_min=0.25) <= 1.1 * _demo_rmse("doppler_slip")


def test_fused_error_floor_on_gentle_doppler_drives():
    # urban_highway seed 0: measured 0.0245 deg (before 0.0355); demo over five seeds: 0.0166
    # (the undeflated floor 0.0203): each bound sits at 40 % of the gain from the new value,
    # so seed-level changes elsewhere do not trip it but the old floor does
    assert _demo_rmse("fused", adapt_min=0.25) <= 0.0181
    highway = _run("fused", "urban_highway", adapt_min=0.25)
    assert metrics(highway[0], highway[1].series)["beta_rmse_deg"] <= 0.029
    for drive, est in (_run("fused", "demo", adapt_min=0.25), highway):
        # and the sigma stays honest (compare_methods' 2-sigma share, 0.95 for a calibrated
        # Gaussian)
        gate = drive["ref_vx"] > SPEED_GATE
        err = np.abs(wrap_angle(est["beta"] - drive["ref_beta"]))[gate]
        assert np.mean(err < 2 * est["beta_std"][gate]) >= 0.95


def test_the_old_floor_is_the_undeflated_axle_noise():
    # with the factor held at >= 1 (the default) the floor comes back: the gain is the
    # identified axle noise, nothing else (five demo seeds: 0.0203 -> 0.0166, 0.82)
    assert _demo_rmse("fused", adapt_min=0.25) < 0.9 * _demo_rmse("fused")


def test_without_gnss_the_axle_noise_is_not_deflated():
    # without GNSS the tyres are the only v_y cue: adapt_min has no effect
    full = sim_drive("step_steer")
    cols = {"t": full.t, **{k: v for k, v in full.data.items() if not k.startswith("gnss_")}}
    drive = drive_from_columns(cols, dict(full.meta))
    vehicle = load_vehicle(drive.meta["vehicle"])
    a = run_method("fused", drive, vehicle, {"adapt_min": 0.25})
    b = run_method("fused", drive, vehicle, {"adapt_min": 1.0})
    assert np.array_equal(a["beta"], b["beta"])
