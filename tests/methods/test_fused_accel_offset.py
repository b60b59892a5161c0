"""fused takes the lateral accelerometer's offset out of its axle forces where the curves'
heading closure (seed 000, through doppler_slip's scan) decides it."""

from __future__ import annotations

import math

import numpy as np
import pytest

from sideslip.drive import Drive
from sideslip.evaluate import metrics
from sideslip.methods.fused_accel_offset import candidate_curves, lateral_accel_offset
from sideslip.methods.registry import run_method
from sideslip.vehicle import load_vehicle
from tests.conftest import sim_drive


def _bank_rmse_deg(drive: Drive, bank: np.ndarray) -> float:
    return math.degrees(float(np.sqrt(np.mean((bank - drive["ref_bank"]) ** 2))))


@pytest.mark.parametrize("seed", [0, 2])
def test_the_offset_the_curves_decide_leaves_beta_and_the_bank(seed: int) -> None:
    """urban_highway (the simulator's nonlinear model, 11 curves, an accelerometer reading
    0.058 / 0.057 m/s^2 high with its mounting misalignment; truth: the drawn
    ``ay_bias_level``, the reference beta and bank).  The scan's posterior lies within 2 sigma
    of the truth, and taking it out of the axle forces and the bank lowers both errors
    (measured: beta 0.024 -> 0.014 and 0.025 -> 0.018 deg, bank 0.29 -> 0.09 and 0.30 ->
    0.04 deg); bounds: beta at least 15 % lower, bank at least halved."""
    drive = sim_drive("urban_highway", seed)
    vehicle = load_vehicle(drive.meta["vehicle"])
    off = run_method("fused", drive, vehicle, {"identify_accel_offset": False})
    on = run_method("fused", drive, vehicle)
    p = on.params
    assert p["accel_offset_y_informed"] is True
    truth = drive.meta["truth_sensor"]["ay_bias_level"]
    assert abs(p["accel_offset_y_m_s2"] - truth) < 2.0 * p["accel_offset_y_m_s2_sigma"]
    assert p["accel_offset_y_m_s2_sigma"] < 0.25  # tighter than the prior
    assert "heading-closure scan in" in p["accel_offset_y_note"]
    beta_off, beta_on = metrics(drive, off.series)["beta_rmse_deg"], metrics(drive, on.series)["beta_rmse_deg"]
    assert beta_on < 0.85 * beta_off
    assert _bank_rmse_deg(drive, on["bank"]) < 0.5 * _bank_rmse_deg(drive, off["bank"])
    assert off.params["accel_offset_y_note"] == "off (FusedSettings.identify_accel_offset)"
    fast = drive["ref_vx"] > 5.0
    err = np.abs(on["beta"] - drive["ref_beta"])[fast]
    assert np.mean(err < 2.0 * on["beta_std"][fast]) >= 0.95


def test_a_drive_with_too_few_curves_keeps_the_prior_and_says_why() -> None:
    """demo (114 s, three turns on the gyro): fewer curves than the scan needs, so no scan runs; the
    offset stays 0 with the prior's sigma, and the note gives the count."""
    drive = sim_drive("demo", 0)
    vehicle = load_vehicle(drive.meta["vehicle"])
    offset = lateral_accel_offset(drive, vehicle, 0.25)
    assert not offset.informed and offset.value == 0.0 and offset.sigma == 0.25
    assert "curves on the gyro (the scan needs 5)" in offset.note
    est = run_method("fused", drive, vehicle)
    assert est.params["accel_offset_y_note"] == offset.note


def test_candidate_curves_count_turns_of_a_biased_gyro() -> None:
    """Analytic: 6 curves of 8 s at 0.1 rad/s (46 deg each) between 20 s straights, on a
    gyro 0.02 rad/s off (more than the 0.024 rad/s threshold's slack would allow without the
    median's removal), at 20 m/s: six; a 2 s blip of the same rate is no curve."""
    t = np.arange(0.0, 200.0, 0.01)
    r = np.zeros(t.size)
    for k in range(6):
        r[(t >= 20 + 28 * k) & (t < 28 + 28 * k)] = 0.1 * (-1) ** k
    r[(t >= 190) & (t < 192)] = 0.1
    cols = {"wz": r + 0.02, "v_can": np.full(t.size, 20.0)}
    assert candidate_curves(Drive(t, cols)) == 6


def test_the_causal_filter_takes_the_smoothers_offset() -> None:
    drive = sim_drive("urban_highway", 0)
    vehicle = load_vehicle(drive.meta["vehicle"])
    smoothed = run_method("fused", drive, vehicle).params
    causal = run_method("fused_filter", drive, vehicle).params
    assert causal["accel_offset_y_m_s2"] == smoothed["accel_offset_y_m_s2"]
    assert causal["accel_offset_y_informed"] is True
    strict = run_method("fused_filter", drive, vehicle, {"whole_drive_calibration": False}).params
    assert strict["accel_offset_y_note"] == "causal without whole_drive_calibration"


def test_a_scan_that_fails_keeps_the_prior_and_a_flipped_gyro_is_one_clear_error(monkeypatch) -> None:
    """The scan is a refinement: where its heading fit fails the offset stays the prior's and
    the note says so.  A yaw gyro turning against the GNSS course stops fused as it stops
    doppler_slip: one error naming the column."""
    from dataclasses import replace

    import sideslip.methods.doppler_slip as ds
    from sideslip.errors import InputError

    drive = sim_drive("urban_highway", 0)
    vehicle = load_vehicle(drive.meta["vehicle"])
    flipped = replace(drive, data={**drive.data, "wz": -np.asarray(drive.data["wz"])})
    with pytest.raises(InputError, match="yaw rate turns opposite to the GNSS course") as err:
        lateral_accel_offset(flipped, vehicle, 0.25)
    assert err.value.column == "wz"

    def broken(*args: object, **kwargs: object) -> None:
        raise RuntimeError("heading fit did not run")

    monkeypatch.setattr(ds, "run_doppler_slip", broken)
    offset = lateral_accel_offset(drive, vehicle, 0.25)
    assert not offset.informed and offset.value == 0.0 and offset.sigma == 0.25
    assert offset.note == "heading-closure scan failed (heading fit did not run); prior 0 +- 0.25 m/s^2"
