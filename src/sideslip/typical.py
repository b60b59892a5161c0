"""Typical passenger-car values, used where a rough vehicle file lacks a key: the one place.

Users' vehicle files often give mass, wheelbase split and a tyre stiffness but not the track,
roll data, steering ratio or slip gain.  A method that falls back on one of these values says so
in its params with :func:`typical_note`, so that a user sees which numbers were assumed.

Sources are ranges for production passenger cars (Gillespie, *Fundamentals of Vehicle
Dynamics*, SAE 1992, ch. 6-8; Milliken & Milliken, *Race Car Vehicle Dynamics*, SAE 1995,
ch. 16-18); the value is the middle of the range, not tuned to any drive.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from sideslip.vehicle import Vehicle


@dataclass(frozen=True)
class Typical:
    """One typical value: ``value`` in SI ``unit``, and the range it stands for."""

    value: float
    unit: str
    range_text: str


TYPICAL: dict[str, Typical] = {
    "track_m": Typical(1.55, "m", "1.45-1.65 m for passenger cars"),
    "roll_frequency_hz": Typical(1.5, "Hz", "body roll natural frequency 1.2-2 Hz"),
    "roll_damping_ratio": Typical(0.5, "-", "roll damping ratio 0.3-0.7"),
    "slip_gain_k_s2_m": Typical(
        0.005, "s^2/m", "rear-axle slip gain 0.003-0.008 s^2/m (seed 000: 0.007-0.008)"
    ),
    "steering_ratio": Typical(15.0, "-", "steering-wheel to road-wheel ratio 13-18"),
    "understeer_gradient_rad_m_s2": Typical(0.0025, "rad/(m/s^2)", "1-4 deg/g"),
}


def typical_note(key: str) -> str:
    """Text for a method's params: ``"assumed 1.55 m (typical: 1.45-1.65 m ...)"``."""
    t = TYPICAL[key]
    return f"assumed {t.value:g} {t.unit} (typical: {t.range_text}; the vehicle file gives none)"


def track_rear(vehicle: Vehicle) -> tuple[float, str]:
    """Rear track (m) and where it came from: the file's track_rear, else its track_front, else
    the typical value."""
    if math.isfinite(vehicle.track_rear):
        return float(vehicle.track_rear), "vehicle file"
    if math.isfinite(vehicle.track_front):
        return float(vehicle.track_front), "vehicle file's track_front (no track_rear)"
    return TYPICAL["track_m"].value, typical_note("track_m")


def slip_gain_k(vehicle: Vehicle) -> tuple[float, str]:
    """Seed 000's slip gain K (s^2/m) from the file (m lf / (L cr)), else the typical value."""
    if not vehicle.missing(["mass", "lf", "lr", "cr"]):
        k = vehicle.slip_gain_k
        if math.isfinite(k) and k > 0:
            return float(k), "vehicle file"
    return TYPICAL["slip_gain_k_s2_m"].value, typical_note("slip_gain_k_s2_m")


def steering_ratio(vehicle: Vehicle) -> tuple[float, str]:
    """Steering ratio (-) from the file, else the typical value."""
    if math.isfinite(vehicle.steering_ratio):
        return float(vehicle.steering_ratio), "vehicle file"
    return TYPICAL["steering_ratio"].value, typical_note("steering_ratio")


def understeer_gradient(vehicle: Vehicle) -> tuple[float, str]:
    """Understeer gradient (rad/(m/s^2)) from the file or its tyres, else the typical value."""
    kus = vehicle.understeer_gradient
    if math.isfinite(kus):
        return float(kus), "vehicle file"
    return TYPICAL["understeer_gradient_rad_m_s2"].value, typical_note("understeer_gradient_rad_m_s2")
