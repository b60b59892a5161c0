"""Output conventions on request, for users of OxTS/VBOX-style tools (``sideslip estimate``).

The contract's output is ENU with yaw from East counter-clockwise in rad.  On request extra
columns are added beside it, never instead of it:

* ``north-cw-deg``: ``M.heading_deg`` = heading from North, clockwise, in degrees [0, 360)
  (``heading = 90 deg - yaw``), as inertial navigation systems report it;
* geodetic: ``M.lat``, ``M.lon`` (degrees, WGS-84) of ``M.e``, ``M.n`` when the drive's metadata
  holds the ENU ``origin`` (lat, lon, h); the height is the origin's.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Literal

import numpy as np

from sideslip.drive import Drive
from sideslip.errors import InputError
from sideslip.estimate import Estimate
from sideslip.frames import enu_to_geodetic

HeadingConvention = Literal["enu-ccw-rad", "north-cw-deg"]
HEADING_CONVENTIONS = ("enu-ccw-rad", "north-cw-deg")


def heading_north_cw_deg(yaw_rad: np.ndarray) -> np.ndarray:
    """Heading from North, clockwise, degrees in [0, 360), of yaw from East counter-clockwise."""
    return np.mod(90.0 - np.degrees(np.asarray(yaw_rad, dtype=float)), 360.0)


def drive_origin(drive: Drive) -> tuple[float, float, float]:
    """The ENU origin (lat deg, lon deg, h m) of the drive's metadata; InputError without one."""
    origin = drive.meta.get("origin")
    try:
        lat, lon, *rest = (float(v) for v in origin)  # type: ignore[union-attr]
    except (TypeError, ValueError):
        raise InputError(
            drive.path,
            "no ENU origin in the drive's metadata: expected origin = [lat, lon, h] (degrees, m) in "
            "its .meta.json for geodetic output",
        ) from None
    if abs(lat) > 90 or abs(lon) > 180:
        raise InputError(drive.path, f"origin {origin!r}: expected latitude and longitude in degrees")
    return lat, lon, rest[0] if rest else 0.0


def with_conventions(
    drive: Drive,
    estimates: Sequence[Estimate],
    heading: HeadingConvention = "enu-ccw-rad",
    geodetic: bool = False,
) -> list[Estimate]:
    """The estimates with the requested extra series (``heading_deg``, ``lat``, ``lon``)."""
    if heading not in HEADING_CONVENTIONS:
        raise InputError(
            "--heading-convention", f"{heading!r}: expected one of {', '.join(HEADING_CONVENTIONS)}"
        )
    origin = drive_origin(drive) if geodetic else None
    out = []
    for est in estimates:
        extra: dict[str, np.ndarray] = {}
        if heading == "north-cw-deg" and "yaw" in est.series:
            extra["heading_deg"] = heading_north_cw_deg(est.series["yaw"])
        if origin is not None and "e" in est.series and "n" in est.series:
            e, n = np.asarray(est.series["e"], float), np.asarray(est.series["n"], float)
            lat, lon, _ = enu_to_geodetic(np.column_stack([e, n, np.zeros_like(e)]), origin)
            extra["lat"], extra["lon"] = lat, lon
        if extra:
            est = Estimate(est.method, est.t, {**est.series, **extra}, est.params, est.innovations)
        out.append(est)
    return out
