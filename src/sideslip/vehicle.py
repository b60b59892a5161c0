"""Vehicle parameters (contract section 2): TOML loading, presets, derived quantities.

Cornering stiffness ``cf``/``cr`` is per axle in N/rad.  Papers that quote it per tyre
(seed 003, seed 000's ``K_r``) are converted on the way in: per-axle = 2 x per-tyre.
"""

from __future__ import annotations

import json
import math
import os
import tempfile
import tomllib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, fields
from importlib import resources
from pathlib import Path
from typing import Any

from sideslip.errors import InputError

G = 9.80665  # standard gravity, m/s^2

# name -> (unit, lower bound, upper bound): bounds are "absurd" limits, not typical ranges.
PARAMETERS: dict[str, tuple[str, float, float]] = {
    "mass": ("kg", 100.0, 60000.0),
    "yaw_inertia": ("kg m^2", 10.0, 1.0e6),
    "lf": ("m", 0.1, 10.0),
    "lr": ("m", 0.1, 10.0),
    "cf": ("N/rad", 1.0e3, 5.0e6),
    "cr": ("N/rad", 1.0e3, 5.0e6),
    "track_front": ("m", 0.5, 3.5),
    "track_rear": ("m", 0.5, 3.5),
    "cg_height": ("m", 0.1, 3.0),
    "roll_axis_height": ("m", -0.5, 3.0),
    "roll_stiffness": ("N m/rad", 1.0e3, 1.0e7),
    "roll_damping": ("N m s/rad", 10.0, 1.0e6),
    "roll_inertia": ("kg m^2", 5.0, 1.0e6),
    "steering_ratio": ("-", 1.0, 40.0),
}
OPTIONAL_PARAMETERS: dict[str, tuple[str, float, float]] = {
    "understeer_gradient": ("rad/(m/s^2)", -0.05, 0.05),
}


@dataclass(frozen=True)
class Vehicle:
    """Vehicle parameters in SI units.  A parameter the file lacks is NaN; use :meth:`need`.

    Attributes are those of the contract: ``mass`` (kg), ``yaw_inertia`` (kg m^2), ``lf``/``lr``
    (CG to front/rear axle, m), ``cf``/``cr`` (cornering stiffness per axle, N/rad),
    ``track_front``/``track_rear`` (m), ``cg_height`` (m above ground), ``roll_axis_height``
    (m above ground), ``roll_stiffness`` (N m/rad), ``roll_damping`` (N m s/rad),
    ``roll_inertia`` (kg m^2, about the roll axis), ``steering_ratio`` (steering-wheel angle
    over road-wheel angle), ``understeer_gradient`` (rad/(m/s^2); NaN -> derived from the
    tyres), lever arms ``imu_xyz``/``gnss_xyz`` (m from the CG, vehicle axes).
    """

    name: str
    source: str
    mass: float = math.nan
    yaw_inertia: float = math.nan
    lf: float = math.nan
    lr: float = math.nan
    cf: float = math.nan
    cr: float = math.nan
    track_front: float = math.nan
    track_rear: float = math.nan
    cg_height: float = math.nan
    roll_axis_height: float = math.nan
    roll_stiffness: float = math.nan
    roll_damping: float = math.nan
    roll_inertia: float = math.nan
    steering_ratio: float = math.nan
    understeer_gradient_given: float = math.nan
    imu_xyz: tuple[float, float, float] = (0.0, 0.0, 0.0)
    gnss_xyz: tuple[float, float, float] = (0.0, 0.0, 0.0)

    # ---- access ---------------------------------------------------------------------
    def missing(self, names: tuple[str, ...] | list[str]) -> list[str]:
        """Names among ``names`` whose value the vehicle file did not give."""
        out = []
        for name in names:
            value = getattr(self, name)
            if isinstance(value, float) and not math.isfinite(value):
                out.append(name)
        return out

    def need(self, *names: str) -> None:
        """Raise :class:`InputError` naming the first parameter among ``names`` that is missing."""
        for name in self.missing(list(names)):
            raise InputError(
                self.source,
                f"parameter '{name}' is needed here but the vehicle file does not give it",
                column=None,
            )

    # ---- derived quantities -----------------------------------------------------------
    @property
    def wheelbase(self) -> float:
        """L = lf + lr, m."""
        return self.lf + self.lr

    @property
    def understeer_gradient_tyres(self) -> float:
        """K_us = m/L (lr/cf - lf/cr), rad/(m/s^2), from the linear single-track model."""
        return self.mass / self.wheelbase * (self.lr / self.cf - self.lf / self.cr)

    @property
    def understeer_gradient(self) -> float:
        """The file's understeer gradient if given, else :attr:`understeer_gradient_tyres`."""
        if math.isfinite(self.understeer_gradient_given):
            return self.understeer_gradient_given
        return self.understeer_gradient_tyres

    @property
    def characteristic_speed(self) -> float:
        """v_ch = sqrt(L/K_us), m/s, where the yaw-rate gain r/delta peaks (inf if K_us <= 0)."""
        kus = self.understeer_gradient
        return math.sqrt(self.wheelbase / kus) if kus > 0 else math.inf

    @property
    def slip_gain_k(self) -> float:
        """Seed 000's slip gain K = m lf / (2 L K_r), s^2/m, with K_r per tyre (= cr/2).

        Steady-state linear single-track: the sideslip at the rear-axle centre is
        beta_r = -K a_y.  With per-axle cr this is K = m lf / (L cr).
        """
        k_r_per_tyre = self.cr / 2.0
        return self.mass * self.lf / (2.0 * self.wheelbase * k_r_per_tyre)

    @property
    def static_roll_gain(self) -> float:
        """Steady-state suspension roll per lateral acceleration, rad/(m/s^2): m h / k.

        h is the CG height above the roll axis (seed 003 eq 41, steady state eq 43).
        """
        return self.mass * (self.cg_height - self.roll_axis_height) / self.roll_stiffness

    def with_changes(self, **changes: Any) -> Vehicle:
        """A copy with some parameters replaced (e.g. a 30 % wrong cornering stiffness)."""
        values = {f.name: getattr(self, f.name) for f in fields(self)}
        values.update(changes)
        return Vehicle(**values)


def _parse(table: dict[str, Any], source: str, name: str) -> Vehicle:
    if "vehicle" not in table or not isinstance(table["vehicle"], dict):
        raise InputError(source, "expected a [vehicle] table with the contract's parameters")
    veh = table["vehicle"]
    values: dict[str, Any] = {}
    for key, (unit, lo, hi) in {**PARAMETERS, **OPTIONAL_PARAMETERS}.items():
        if key not in veh:
            if key in PARAMETERS and key in ("mass", "lf", "lr"):
                raise InputError(source, f"parameter '{key}' is missing: expected a number in {unit}")
            continue
        raw = veh[key]
        if isinstance(raw, bool) or not isinstance(raw, int | float) or not math.isfinite(raw):
            raise InputError(source, f"parameter '{key}' = {raw!r}: expected a number in {unit}")
        if not lo <= float(raw) <= hi:
            raise InputError(
                source,
                f"parameter '{key}' = {raw} {unit} is absurd: expected {lo:g} to {hi:g} {unit}",
            )
        field_name = "understeer_gradient_given" if key == "understeer_gradient" else key
        values[field_name] = float(raw)
    sensors = table.get("sensors", veh.get("sensors", {}))
    if isinstance(sensors, dict):
        for key in ("imu_xyz", "gnss_xyz"):
            if key in sensors:
                arm = sensors[key]
                ok = isinstance(arm, list) and len(arm) == 3
                ok = ok and all(isinstance(a, int | float) and abs(a) < 20 for a in arm)
                if not ok:
                    raise InputError(
                        source,
                        f"parameter 'sensors.{key}' = {arm!r}: expected [x, y, z] in m "
                        "from the CG, each within 20 m",
                    )
                values[key] = tuple(float(a) for a in arm)
    return Vehicle(name=str(veh.get("name", name)), source=source, **values)


def preset_names() -> list[str]:
    """Names of the vehicle presets shipped with the package."""
    folder = resources.files("sideslip") / "presets"
    return sorted(p.name[:-5] for p in folder.iterdir() if p.name.endswith(".toml"))


def load_vehicle(name_or_path: str | Path) -> Vehicle:
    """Load a vehicle by preset name (see :func:`preset_names`) or by TOML file path."""
    text = str(name_or_path)
    path = Path(text)
    if path.suffix == ".toml" or path.exists():
        source = text
        try:
            raw = path.read_bytes()
        except OSError as exc:
            raise InputError(source, f"cannot read vehicle file ({exc.strerror})") from None
        stem = path.stem
    else:
        if text not in preset_names():
            raise InputError(
                text,
                "no such vehicle file or preset: expected a .toml path or one of "
                + ", ".join(preset_names()),
            )
        source = f"preset:{text}"
        raw = (resources.files("sideslip") / "presets" / f"{text}.toml").read_bytes()
        stem = text
    try:
        table = tomllib.loads(raw.decode("utf-8"))
    except (tomllib.TOMLDecodeError, UnicodeDecodeError) as exc:
        raise InputError(source, f"not valid TOML ({exc})") from None
    return _parse(table, source, stem)


# ---- writing ------------------------------------------------------------------------------
TomlValue = float | int | str
TableRows = Sequence[tuple[str, TomlValue, str]]


def _toml_value(value: TomlValue | tuple[float, ...]) -> str:
    if isinstance(value, str):
        return json.dumps(value)  # a JSON string is a valid TOML basic string
    if isinstance(value, tuple):
        return "[" + ", ".join(_toml_value(v) for v in value) + "]"
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if not math.isfinite(value):
        raise ValueError(f"cannot write {value!r} to TOML: expected a finite number")
    return repr(float(value))


def _comment(text: str) -> list[str]:
    return [f"# {line}" if line else "#" for line in text.splitlines()] if text else []


def vehicle_to_toml(
    vehicle: Vehicle,
    notes: Mapping[str, str] | None = None,
    tables: Mapping[str, TableRows] | None = None,
    header: Sequence[str] = (),
) -> str:
    """A vehicle file (contract section 2) that :func:`load_vehicle` reads back to ``vehicle``.

    ``notes`` maps a parameter key (``cf``, ``sensors.gnss_xyz``, ...) to a comment written on
    the lines above it; parameters the vehicle lacks (NaN) are left out, with their note if
    one is given.  ``tables`` adds the user's own tables (e.g. ``[calibration]``,
    ``[notes]``; ignored by the loader) as rows ``(key, value, comment)``.
    """
    notes = notes or {}
    lines = [*_comment("\n".join(header))]
    lines += ["[vehicle]", f"name = {_toml_value(vehicle.name)}"]
    for key in (*PARAMETERS, *OPTIONAL_PARAMETERS):
        field_name = "understeer_gradient_given" if key == "understeer_gradient" else key
        value = float(getattr(vehicle, field_name))
        lines += _comment(notes.get(key, ""))
        if math.isfinite(value):
            lines.append(f"{key} = {_toml_value(value)}")
        elif key in notes:
            lines.append(f"# {key} not given")
    lines += ["", "[sensors]"]
    for key in ("imu_xyz", "gnss_xyz"):
        lines += _comment(notes.get(f"sensors.{key}", ""))
        lines.append(f"{key} = {_toml_value(tuple(float(a) for a in getattr(vehicle, key)))}")
    for table, rows in (tables or {}).items():
        lines += ["", f"[{table}]"]
        for key, cell, comment in rows:
            lines += _comment(comment)
            lines.append(f"{key} = {_toml_value(cell)}")
    return "\n".join(lines) + "\n"


def save_vehicle(
    vehicle: Vehicle,
    path: str | Path,
    notes: Mapping[str, str] | None = None,
    tables: Mapping[str, TableRows] | None = None,
    header: Sequence[str] = (),
) -> None:
    """Write :func:`vehicle_to_toml` to ``path`` atomically (never half-written)."""
    save_vehicle_text(vehicle_to_toml(vehicle, notes, tables, header), path)


def save_vehicle_text(text: str, path: str | Path) -> None:
    """Write vehicle-file text atomically: a temporary file in the same folder, then rename."""
    p = Path(path)
    if p.suffix.lower() != ".toml":
        raise InputError(str(path), "expected an output path ending in .toml")
    tomllib.loads(text)  # never write a file that would not load
    try:
        p.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(dir=p.parent, prefix=f".{p.name}.", suffix=".part")
    except OSError as exc:
        raise InputError(str(path), f"cannot write ({exc.strerror})") from None
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as fh:
            fh.write(text)
        umask = os.umask(0)
        os.umask(umask)
        os.chmod(tmp, 0o666 & ~umask)
        os.replace(tmp, p)
    except BaseException:
        Path(tmp).unlink(missing_ok=True)
        raise
