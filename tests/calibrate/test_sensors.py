"""The drive's own gyro zero (:func:`sideslip.calibrate.sensors.drive_gyro_bias`): a raw MEMS
gyro's bias of degrees per second, as on the comma2k19 phone (-3.9 deg/s), on drives from the
simulator's nonlinear truth.  The methods that subtract it are tested in their own files
(test_observers, test_factor_graph, test_kkf)."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from sideslip.calibrate.sensors import drive_gyro_bias
from sideslip.drive import Drive
from sideslip.vehicle import load_vehicle
from tests.conftest import sim_drive
from tests.helpers import PHONE_BIAS, raw_gyro


def _without_gnss(drive: Drive) -> Drive:
    return replace(drive, data={k: v for k, v in drive.data.items() if not k.startswith("gnss")})


def test_drive_zero_recovers_a_phone_class_bias() -> None:
    """demo (GNSS Doppler, 6 s standstill at the start): the zero is the added 3 deg/s plus the
    simulated gyro's own bias (the mean of w_z - r cos(roll) against the reference) within
    0.05 deg/s, about 3 of the fit's 1-sigma (0.015 deg/s)."""
    drive = sim_drive("demo")
    vehicle = load_vehicle(drive.meta["vehicle"])
    zero = drive_gyro_bias(raw_gyro(drive), vehicle.gnss_xyz)
    own = float(np.nanmean(drive["wz"] - drive["ref_r"] * np.cos(drive["ref_roll"])))
    assert zero.informed
    assert math.degrees(abs(zero.value - PHONE_BIAS - own)) < 0.05
    assert 0 < math.degrees(zero.sigma) < 0.05


def test_drive_zero_is_not_invented_without_gnss_or_standstill() -> None:
    """cr_circle without its GNSS columns: no course and no standstill, so nothing to tell the
    bias from; the zero is 0 and says why (the methods then use the samples as recorded)."""
    drive = _without_gnss(sim_drive("cr_circle"))
    zero = drive_gyro_bias(drive, (0.0, 0.0, 0.0))
    assert not zero.informed
    assert zero.value == 0.0
    assert "standstill" in zero.note and "GNSS course" in zero.note
