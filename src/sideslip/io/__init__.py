"""Adapters for outside recordings: ``sideslip convert FORMAT SRC --out DRIVE [--map MAP]``.

The CLI calls :func:`convert` and then :func:`sideslip.drive.save_drive`; :data:`FORMATS` lists
the formats for ``sideslip convert --help``.
"""

from __future__ import annotations

from pathlib import Path

from sideslip.drive import Drive
from sideslip.errors import InputError
from sideslip.vehicle import Vehicle, load_vehicle

FORMATS: dict[str, str] = {
    "comma2k19": "a comma2k19 segment folder (processed_log/ + global_pose/); IMU, CAN, u-blox "
    "and the global pose as reference; --vehicle for the steering ratio (default rav4 for the "
    "RAV4 dongle)",
    "csv": "a CSV with its own column names and units, mapped by --map MAP.toml (optional raw "
    "CAN frames decoded with a DBC)",
    "revs": "a Stanford Revs lap folder of .txt columns (seed 002's Ferrari 250 LM lap)",
    "mdf4": "an ASAM MDF4 file (.mf4), channels mapped by --map MAP.toml (optional raw CAN "
    "frames decoded with a DBC)",
    "rosbag": "a ROS 1 .bag or ROS 2 bag folder (rosbags): sensor_msgs/Imu, NavSatFix, "
    "TwistStamped topics and numeric fields of any message, mapped by --map MAP.toml",
}


TEMPLATES = ("csv", "mdf4", "rosbag")  # formats mapped by a MAP.toml: `convert --template FMT`


def template(fmt: str) -> str:
    """The commented example map of a mapped format (``sideslip convert --template FMT``)."""
    from importlib import resources

    if fmt not in TEMPLATES:
        raise InputError("--template", f"'{fmt}': expected one of {', '.join(TEMPLATES)}")
    return resources.files("sideslip.io").joinpath("templates", f"{fmt}.toml").read_text(encoding="utf-8")


def convert(fmt: str, src: Path, vehicle: Vehicle | None, map_path: Path | None) -> Drive:
    """Turn an outside recording into a validated drive; bad input raises InputError."""
    if fmt not in FORMATS:
        raise InputError(str(src), f"format {fmt!r} unknown: expected one of "
                         + ", ".join(FORMATS))
    if fmt == "comma2k19":
        from sideslip.io.comma2k19 import convert_comma2k19, default_vehicle_name

        if not Path(src).is_dir():
            raise InputError(str(src), "expected a comma2k19 segment folder (processed_log/, "
                             "global_pose/)")
        if vehicle is None:
            name = default_vehicle_name(src)
            if name is None:
                raise InputError(str(src), "the car of this segment has no preset: expected "
                                 "--vehicle NAME_OR_TOML (steering ratio needed)")
            vehicle = load_vehicle(name)
        return convert_comma2k19(src, vehicle)
    if fmt == "revs":
        from sideslip.io.revs import convert_revs

        return convert_revs(src)
    if map_path is None:
        raise InputError(str(src), f"format {fmt!r} needs a channel map: expected --map MAP.toml "
                         f"(start from: sideslip convert --template {fmt})")
    if fmt == "rosbag":
        from sideslip.io.rosbag import convert_rosbag

        return convert_rosbag(src, map_path)
    from sideslip.io.mapping import convert_mapped

    return convert_mapped(src, map_path, fmt)
