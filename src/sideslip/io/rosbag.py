"""ROS 1 (``.bag``) and ROS 2 (folder with ``metadata.yaml``, or ``.mcap``/``.db3``) recordings
to a drive, through ``rosbags`` (extra ``automotive``) and a MAP.toml::

    [time]
    source = "header"        # time stamp of a sample: "header" (header.stamp, default; the
                             # bag's receive time for messages without a header) or "bag"
    base = "wz"              # optional: contract column whose samples are the drive's rows

    [topics.imu]             # whole standard messages (the name after "topics." is free)
    topic = "/imu/data"
    type = "imu"             # sensor_msgs/Imu -> wx, wy, wz, ax, ay, az
    frame = "flu"            # "flu" (REP 103: x forward, y left, z up; default) or "frd"

    [topics.fix]
    topic = "/gnss/fix"
    type = "navsatfix"       # sensor_msgs/NavSatFix -> gnss_lat, gnss_lon, gnss_h (to ENU by
                             # the loader), gnss_pos_std from the covariance; no-fix rows dropped

    [topics.gnss_velocity]
    topic = "/gnss/vel"
    type = "twist"           # geometry_msgs/TwistStamped in ENU -> gnss_ve, gnss_vn, gnss_vu

    [columns.steer]          # any numeric field of any message, by a dotted path
    topic = "/vehicle/steering_report"
    field = "steering_wheel_angle"   # e.g. "data", "twist.linear.x", "position_covariance[0]"
    unit = "rad"
    scale = 0.0625           # 1 / steering ratio: steering-wheel -> road-wheel angle
    sign = 1

Units, ``scale`` and ``sign`` work as in :mod:`sideslip.io.mapping` (``column = sign * scale *
value * unit factor``), and the rows are placed the same way (the base column's samples are the
rows; slower sensors sit on their nearest row).  A bad map, a missing topic or field is one
:class:`InputError` line naming the map or bag, the column and what was expected.
"""

from __future__ import annotations

import math
import re
import tomllib
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from sideslip.drive import COLUMNS, Drive, drive_from_columns
from sideslip.errors import InputError
from sideslip.io.mapping import UNITS, FloatArray, align, column_dimension

MESSAGE_TYPES: dict[str, tuple[str, ...]] = {
    "imu": ("wx", "wy", "wz", "ax", "ay", "az"),
    "navsatfix": ("gnss_lat", "gnss_lon", "gnss_h", "gnss_pos_std"),
    "twist": ("gnss_ve", "gnss_vn", "gnss_vu"),
}
_FIELD = re.compile(r"^[A-Za-z_]\w*(\[\d+\])?(\.[A-Za-z_]\w*(\[\d+\])?)*$")


@dataclass(frozen=True)
class TopicMap:
    """A standard message on ``topic`` giving several columns (``kind`` in MESSAGE_TYPES)."""

    name: str
    topic: str
    kind: str
    frame: str = "flu"


@dataclass(frozen=True)
class FieldMap:
    """One contract column from a numeric ``field`` of the messages on ``topic``."""

    column: str
    topic: str
    field: str
    factor: float


@dataclass(frozen=True)
class BagMap:
    path: str
    topics: tuple[TopicMap, ...]
    fields: tuple[FieldMap, ...]
    header_time: bool
    base: str | None

    def columns(self) -> list[str]:
        out = [c for t in self.topics for c in MESSAGE_TYPES[t.kind]]
        return out + [f.column for f in self.fields]


def _text(entry: dict[str, Any], key: str, path: str, where: str) -> str:
    value = entry.get(key)
    if not isinstance(value, str) or not value:
        raise InputError(path, f'{key} missing: expected {key} = "..." in quotes', column=where)
    return value


def _factor(entry: dict[str, Any], name: str, path: str) -> float:
    dim = column_dimension(name)
    allowed = [u for u, (d, _) in UNITS.items() if d == dim]
    unit = entry.get("unit")
    if unit not in UNITS or UNITS[str(unit)][0] != dim:
        raise InputError(path, f"unit = {unit!r}: expected one of {', '.join(allowed)}", column=name)
    numbers = {}
    for key in ("scale", "sign"):
        raw = entry.get(key, 1.0)
        if isinstance(raw, bool) or not isinstance(raw, int | float) or not math.isfinite(raw) or raw == 0:
            raise InputError(path, f"{key} = {raw!r}: expected a non-zero finite number", column=name)
        numbers[key] = float(raw)
    if numbers["sign"] not in (1.0, -1.0):
        raise InputError(path, f"sign = {entry['sign']!r}: expected 1 or -1", column=name)
    factor = UNITS[str(unit)][1]
    if dim == "angle" and name not in COLUMNS:
        factor /= UNITS["deg"][1]  # geodetic lat/lon stay in degrees for the drive loader
    return numbers["sign"] * numbers["scale"] * factor


def load_bag_map(map_path: str | Path) -> BagMap:
    """Parse and check a rosbag MAP.toml (see the module docstring)."""
    path = str(map_path)
    try:
        table = tomllib.loads(Path(map_path).read_text(encoding="utf-8"))
    except OSError as exc:
        raise InputError(path, f"cannot read the map file ({exc.strerror})") from None
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise InputError(path, f"not valid TOML ({exc})") from None
    time_tab = table.get("time", {})
    source = time_tab.get("source", "header") if isinstance(time_tab, dict) else None
    if source not in ("header", "bag"):
        raise InputError(path, f'[time] source = {source!r}: expected "header" or "bag"', column="t")
    topics = []
    for name, entry in (table.get("topics") or {}).items():
        if not isinstance(entry, dict):
            raise InputError(path, f"[topics.{name}] must be a table with topic and type")
        kind = entry.get("type")
        if kind not in MESSAGE_TYPES:
            raise InputError(
                path, f"[topics.{name}] type = {kind!r}: expected one of {', '.join(MESSAGE_TYPES)}"
            )
        frame = entry.get("frame", "flu")
        if frame not in ("flu", "frd"):
            raise InputError(path, f'[topics.{name}] frame = {frame!r}: expected "flu" or "frd"')
        topics.append(TopicMap(name, _text(entry, "topic", path, f"topics.{name}"), kind, frame))
    fields = []
    for name, entry in (table.get("columns") or {}).items():
        if column_dimension(name) is None or name == "t":
            raise InputError(path, "not a contract column: expected one of "
                             + ", ".join(c for c in COLUMNS if c != "t"), column=name)  # fmt: skip
        if not isinstance(entry, dict):
            raise InputError(path, "expected a table with topic, field and unit", column=name)
        field = _text(entry, "field", path, name)
        if not _FIELD.match(field):
            raise InputError(
                path, f"field = {field!r}: expected a dotted path such as twist.linear.x", column=name
            )
        fields.append(FieldMap(name, _text(entry, "topic", path, name), field, _factor(entry, name, path)))
    bmap = BagMap(path, tuple(topics), tuple(fields), source == "header", time_tab.get("base"))
    cols = bmap.columns()
    if not cols:
        raise InputError(path, "expected [topics.<name>] or [columns.<name>] tables mapping the bag")
    dup = next((c for c in cols if cols.count(c) > 1), None)
    if dup is not None:
        raise InputError(path, "mapped twice: expected each column from one topic", column=dup)
    if bmap.base is not None and bmap.base not in cols:
        raise InputError(path, f"[time] base = {bmap.base!r}: expected one of the mapped columns", column="t")
    return bmap


# ------------------------------------------------------------------------------------------
# reading messages
# ------------------------------------------------------------------------------------------
def get_field(msg: Any, field: str) -> Any:
    """``msg.twist.linear.x`` for ``"twist.linear.x"``; ``[i]`` indexes arrays; KeyError if absent."""
    value = msg
    for part in field.split("."):
        name, _, index = part.partition("[")
        if not hasattr(value, name):
            raise KeyError(part)
        value = getattr(value, name)
        if index:
            value = value[int(index[:-1])]
    return value


def _stamp(msg: Any, bag_ns: int, header_time: bool) -> float:
    stamp = getattr(getattr(msg, "header", None), "stamp", None)
    if header_time and stamp is not None:
        t = float(stamp.sec) + 1e-9 * float(stamp.nanosec)
        if t > 0:
            return t
    return 1e-9 * bag_ns


def _imu(msg: Any, frame: str) -> list[float]:
    w, a = msg.angular_velocity, msg.linear_acceleration
    s = -1.0 if frame == "frd" else 1.0  # FRD -> FLU: y and z change sign
    return [w.x, s * w.y, s * w.z, a.x, s * a.y, s * a.z]


def _navsatfix(msg: Any, frame: str) -> list[float]:
    if int(msg.status.status) < 0:  # STATUS_NO_FIX
        return [math.nan] * 4
    cov = np.asarray(msg.position_covariance, dtype=float)
    known = int(msg.position_covariance_type) > 0 and cov.size == 9
    std = math.sqrt(max(0.0, 0.5 * (cov[0] + cov[4]))) if known else math.nan
    return [msg.latitude, msg.longitude, msg.altitude, std]


def _twist(msg: Any, frame: str) -> list[float]:
    v = msg.twist.linear
    return [v.x, v.y, v.z]


_READERS: dict[str, Callable[[Any, str], list[float]]] = {
    "imu": _imu,
    "navsatfix": _navsatfix,
    "twist": _twist,
}


def read_bag(bag: str | Path, bmap: BagMap) -> dict[str, tuple[FloatArray, FloatArray]]:
    """Every mapped column as (time s, value in SI) of its own samples."""
    try:
        from rosbags.highlevel import AnyReader
        from rosbags.typesys import Stores, get_typestore
    except ImportError:
        raise InputError(
            str(bag), "reading ROS bags needs rosbags: pip install 'sideslip[automotive]'"
        ) from None
    p = Path(bag)
    if not p.exists():
        raise InputError(str(bag), "cannot read: no such file or folder (a ROS 1 .bag or a ROS 2 bag folder)")
    samples: dict[str, tuple[list[float], list[float]]] = {c: ([], []) for c in bmap.columns()}
    try:
        with AnyReader([p], default_typestore=get_typestore(Stores.ROS2_HUMBLE)) as reader:
            present = {c.topic: c for c in reader.connections}
            wanted = [t.topic for t in bmap.topics] + [f.topic for f in bmap.fields]
            for topic in wanted:
                if topic not in present:
                    known = sorted(present)
                    listed = ", ".join(known[:12]) + (" ..." if len(known) > 12 else "")
                    raise InputError(
                        str(bag),
                        f"topic {topic!r} (map {bmap.path}) not in the bag: expected one of {listed}",
                    )
            conns = [present[t] for t in dict.fromkeys(wanted)]
            for conn, bag_ns, raw in reader.messages(connections=conns):
                msg = reader.deserialize(raw, conn.msgtype)
                t = _stamp(msg, bag_ns, bmap.header_time)
                for tm in bmap.topics:
                    if tm.topic == conn.topic:
                        _add_topic(samples, tm, msg, t, str(bag), conn.msgtype)
                for fm in bmap.fields:
                    if fm.topic == conn.topic:
                        _add_field(samples, fm, msg, t, str(bag), conn.msgtype)
    except InputError:
        raise
    except Exception as exc:  # rosbags raises many types on a damaged or foreign file
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise InputError(str(bag), f"cannot read as a ROS bag: {first}") from None
    out: dict[str, tuple[FloatArray, FloatArray]] = {}
    for col, (ts, vs) in samples.items():
        t_arr, v_arr = np.asarray(ts, dtype=float), np.asarray(vs, dtype=float)
        ok = np.isfinite(t_arr) & np.isfinite(v_arr)
        order = np.argsort(t_arr[ok], kind="stable")
        out[col] = (t_arr[ok][order], v_arr[ok][order])
    return out


def _add_topic(samples: dict[str, Any], tm: TopicMap, msg: Any, t: float, bag: str, msgtype: str) -> None:
    try:
        values = _READERS[tm.kind](msg, tm.frame)
    except AttributeError as exc:
        raise InputError(
            bag, f"topic {tm.topic!r} holds {msgtype}, not a {tm.kind} message ({exc})"
        ) from None
    for col, v in zip(MESSAGE_TYPES[tm.kind], values, strict=True):
        samples[col][0].append(t)
        samples[col][1].append(float(v))


def _add_field(samples: dict[str, Any], fm: FieldMap, msg: Any, t: float, bag: str, msgtype: str) -> None:
    try:
        value = get_field(msg, fm.field)
    except (KeyError, IndexError) as exc:
        raise InputError(bag, f"field {fm.field!r} of {msgtype} on {fm.topic!r}: no {exc.args[0]!r}",
                         column=fm.column) from None  # fmt: skip
    if isinstance(value, bool) or not isinstance(value, int | float | np.number):
        raise InputError(bag, f"field {fm.field!r} of {msgtype} on {fm.topic!r} is "
                         f"{type(value).__name__}: expected a number", column=fm.column)  # fmt: skip
    samples[fm.column][0].append(t)
    samples[fm.column][1].append(float(value) * fm.factor)


def convert_rosbag(bag: str | Path, map_path: str | Path) -> Drive:
    """A ROS 1 or ROS 2 bag to a validated drive, following the rosbag map ``map_path``."""
    bmap = load_bag_map(map_path)
    series = read_bag(bag, bmap)
    cols, report = align(series, bmap.base, str(bag))
    meta = {
        "source": f"rosbag:{Path(bag).name}",
        "map": str(map_path),
        "alignment": report,
        "notes": "time stamps from "
        + ("message headers" if bmap.header_time else "the bag")
        + "; rows are the samples of the base column, slower sensors on their nearest row",
    }
    return drive_from_columns(cols, meta, path=str(bag))
