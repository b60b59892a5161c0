"""What the calibration returns: one :class:`Fitted` per parameter, and the fitted vehicle.

Naming follows the package convention for identified parameters: scale factors as
measured / true (``wheel_speed_scale``, ``gyro_scale``, ``steer_scale``; 1.0 = perfect),
biases and angles with units in the name (``gyro_bias_rad_s``, ``steer_offset_rad``,
``imu_yaw_misalignment_rad``), each with its 1-sigma and the number of drive rows that
informed it.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

from sideslip.vehicle import Vehicle


@dataclass(frozen=True)
class Fitted:
    """One identified parameter.

    ``value`` and ``sigma`` (1-sigma) in ``unit``; ``rows`` drive rows behind it; ``source``
    the relation (and gates) it came from; ``informed`` False when the drive could not tell it
    (then ``value`` is the prior ``before``, the file's or a typical value, left as it was);
    ``file_key`` the vehicle-file key it sets (None: a sensor calibration, written to the
    ``[calibration]`` table); ``note`` why it was left or what it assumes.
    """

    name: str
    value: float
    sigma: float
    rows: int
    source: str
    informed: bool
    unit: str
    before: float = math.nan
    file_key: str | None = None
    note: str = ""

    def as_dict(self) -> dict[str, Any]:
        def clean(x: float) -> float | None:
            return float(x) if math.isfinite(x) else None

        return {
            "value": clean(self.value),
            "sigma": clean(self.sigma),
            "rows": int(self.rows),
            "source": self.source,
            "informed": bool(self.informed),
            "unit": self.unit,
            "before": clean(self.before),
            "file_key": self.file_key,
            "note": self.note,
        }


def left_alone(
    name: str, before: float, unit: str, why: str, file_key: str | None = None, sigma: float = math.nan
) -> Fitted:
    """A parameter the drive could not inform: kept at ``before``, with the reason."""
    return Fitted(name, before, sigma, 0, "not identified", False, unit, before, file_key, why)


@dataclass(frozen=True)
class Calibration:
    """The calibration of one drive: fitted parameters, the fitted vehicle, notes."""

    fitted: tuple[Fitted, ...]
    vehicle: Vehicle
    notes: tuple[str, ...] = ()
    gates: Mapping[str, str] = field(default_factory=dict)

    def get(self, name: str) -> Fitted:
        for f in self.fitted:
            if f.name == name:
                return f
        raise KeyError(name)

    def params(self) -> dict[str, Any]:
        """JSON-friendly: ``name -> value`` and ``name_sigma``, plus per-parameter details."""
        out: dict[str, Any] = {}
        for f in self.fitted:
            out[f.name] = f.value if math.isfinite(f.value) else None
            out[f"{f.name}_sigma"] = f.sigma if math.isfinite(f.sigma) else None
        out["details"] = {f.name: f.as_dict() for f in self.fitted}
        out["notes"] = list(self.notes)
        out["gates"] = dict(self.gates)
        return out


def zero_params(
    zero: Fitted, key: str, name: str, subtracted: bool, significance: float
) -> dict[str, object]:
    """A method's params entries for a sensor zero the drive told (or not): ``key`` (the value,
    e.g. ``gyro_zero_rad_s``), ``key_sigma``, ``name_source``, and ``name_note`` where the drive
    did not tell it or where it was not ``subtracted`` (within ``significance`` sigma of 0)."""
    if not zero.informed:
        return {key: 0.0, f"{name}_note": f"not told by the drive: {zero.note}"}
    out: dict[str, object] = {key: zero.value, f"{key}_sigma": zero.sigma, f"{name}_source": zero.source}
    if not subtracted:
        out[f"{name}_note"] = f"within {significance:g} sigma of 0: not subtracted, the samples as recorded"
    return out
