"""Methods registry: name -> function, the columns it needs, its vehicle parameters, its paper.

A method is a plain function ``f(drive, vehicle) -> Estimate``, or, when it has tuning,
``f(drive, vehicle, settings) -> Estimate`` with ``settings`` an instance of the frozen dataclass
given to :func:`register` (``settings=Cls``; see :mod:`sideslip.settings`).  Modules in
``sideslip.methods`` register theirs with :func:`register`; :func:`all_methods` imports every
module of the package, so a new module needs no edit elsewhere.  :func:`run_method` records the
settings a method ran with in its params (``params["settings"]``).
"""

from __future__ import annotations

import dataclasses
import importlib
import pkgutil
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from sideslip.doppler_timing import drive_on_receiver_time
from sideslip.drive import SPEED_COLUMNS, Drive
from sideslip.errors import InputError
from sideslip.estimate import Estimate, check_estimate
from sideslip.imu_lever import drive_at_cg
from sideslip.imu_timing import drive_on_gnss_clock
from sideslip.settings import make_settings, settings_dict
from sideslip.units_check import (
    MIN_CORRELATION,
    check_gnss_speed_units,
    check_lateral_axes,
    check_lateral_units,
    check_longitudinal,
    check_steer_units,
    check_tilt_rate_units,
    lateral_slope,
)
from sideslip.vehicle import Vehicle

MethodFunc = Callable[..., Estimate]  # (drive, vehicle) or (drive, vehicle, settings)
SPEED = SPEED_COLUMNS  # "one of the wheel speeds or v_can"


@dataclass(frozen=True)
class Method:
    """A registered method.

    ``columns``: each entry is a column name, or a tuple of alternatives of which one suffices.
    ``vehicle_params``: vehicle parameters the method reads.
    ``settings``: the method's settings dataclass (None: the method has no tuning).
    ``accelerometer``: ``"cg"`` (the method takes ``ax``/``ay`` as read at the CG:
    :func:`run_method` moves them there from the vehicle file's ``imu_xyz``,
    :mod:`sideslip.imu_lever`), ``"cg_causal"`` (the same for a causal method: without reading
    later gyro samples) or ``"own"`` (the method reads ``imu_xyz`` itself).
    ``optional``: columns the method reads where the drive has them (``fused``'s GNSS).
    """

    name: str
    func: MethodFunc
    columns: tuple[str | tuple[str, ...], ...]
    vehicle_params: tuple[str, ...]
    summary: str
    paper: str
    settings: type | None = None
    accelerometer: str = "cg"
    optional: tuple[str, ...] = ()

    def default_settings(self) -> Any:
        """The settings the method runs with when the user gives none (None: no tuning)."""
        return self.settings() if self.settings is not None else None

    def columns_text(self) -> str:
        return ", ".join(c if isinstance(c, str) else "|".join(c) for c in self.columns)


_REGISTRY: dict[str, Method] = {}


def register(
    name: str,
    *,
    columns: Sequence[str | tuple[str, ...]],
    summary: str,
    paper: str,
    vehicle_params: Sequence[str] = (),
    settings: type | None = None,
    accelerometer: str = "cg",
    optional: Sequence[str] = (),
) -> Callable[[MethodFunc], MethodFunc]:
    """Decorator: register ``func`` under ``name`` (a lower-case identifier).

    ``settings``: a frozen dataclass of the method's tuning; ``func`` is then called as
    ``func(drive, vehicle, settings)``.  ``accelerometer``, ``optional``: see :class:`Method`.
    """
    if not name.isidentifier() or name != name.lower():
        raise ValueError(f"method name {name!r} must be a lower-case identifier")
    if accelerometer not in ("cg", "cg_causal", "own"):
        raise ValueError(f"accelerometer must be 'cg', 'cg_causal' or 'own', got {accelerometer!r}")

    def deco(func: MethodFunc) -> MethodFunc:
        if name in _REGISTRY and _REGISTRY[name].func is not func:
            raise ValueError(f"method {name!r} registered twice")
        _REGISTRY[name] = Method(
            name, func, tuple(columns), tuple(vehicle_params), summary, paper, settings, accelerometer,
            tuple(optional),
        )
        return func

    return deco


def all_methods() -> dict[str, Method]:
    """Every registered method, importing all modules of ``sideslip.methods`` first."""
    import sideslip.methods as pkg

    for info in pkgutil.iter_modules(pkg.__path__):
        if info.name != "registry" and not info.name.startswith("_"):
            importlib.import_module(f"sideslip.methods.{info.name}")
    return dict(sorted(_REGISTRY.items()))


def missing_columns(method: Method, drive: Drive) -> list[str]:
    """Column requirements of ``method`` that ``drive`` does not meet (as text)."""
    out = []
    for need in method.columns:
        alts = (need,) if isinstance(need, str) else need
        if not any(a in drive for a in alts):
            out.append(need if isinstance(need, str) else " or ".join(alts))
    return out


def why_not(method: Method, drive: Drive, vehicle: Vehicle) -> str | None:
    """The reason ``method`` cannot run on this drive/vehicle, or None when it can."""
    cols = missing_columns(method, drive)
    if cols:
        return "drive lacks " + ", ".join(f"'{c}'" for c in cols)
    params = vehicle.missing(list(method.vehicle_params))
    if params:
        return "vehicle file lacks " + ", ".join(f"'{p}'" for p in params)
    return None


def get_method(name_or_method: str | Method) -> Method:
    """The registered method of that name (or the Method itself); InputError when unknown."""
    if isinstance(name_or_method, Method):
        return name_or_method
    registry = all_methods()
    if name_or_method not in registry:
        raise InputError(
            "method", f"unknown method '{name_or_method}': expected one of {', '.join(registry)}"
        )
    return registry[name_or_method]


def resolve_settings(overrides: Mapping[str, Mapping[str, Any]], where: str = "settings") -> dict[str, Any]:
    """Method name -> settings object from ``{method: {field: value}}`` (TOML or ``--set``).

    An unknown method, a method without settings, an unknown field or a value out of range is
    one InputError line naming ``where``, the method and the field.
    """
    out: dict[str, Any] = {}
    for name, values in overrides.items():
        method = get_method(name) if name in all_methods() else None
        if method is None:
            raise InputError(where, f"unknown method '{name}': expected one of {', '.join(all_methods())}")
        if method.settings is None:
            raise InputError(where, f"method '{name}' has no settings")
        out[name] = make_settings(method.settings, values, f"{where}: {name}")
    return out


def check_gyro_sign(drive: Drive) -> None:
    """Every method: a yaw gyro that turns against the drive's GNSS course (Doppler, else
    fixes) is bad input (:func:`sideslip.methods.doppler_heading.check_yaw_rate_sign`, 1 s
    intervals); without GNSS or ``wz`` there is nothing to compare."""
    if "wz" not in drive or not ("gnss_ve" in drive or "gnss_e" in drive):
        return
    from sideslip import gnss
    from sideslip.methods.doppler_heading import (
        CourseSamples,
        check_yaw_rate_sign,
        yaw_rate_course_correlation,
    )
    from sideslip.signals import vehicle_speed

    if not np.isfinite(drive["wz"]).any():
        return
    speed = vehicle_speed(drive)
    cs = gnss.course_samples(drive, speed, use_positions=True)
    samples = CourseSamples(cs.rows, cs.course, cs.speed, cs.sigma)
    corr = yaw_rate_course_correlation(drive.t, drive["wz"], samples)
    if corr is not None and corr >= 0.5 and "gnss_ve" in drive and "gnss_e" in drive:
        # the Doppler turns with the gyro; the fixes' own course must too (east and north of
        # the positions swapped while the velocities are right: the smoother read 19 deg of
        # beta RMSE on urban_course with 95 % of it flagged, rather than one clear line)
        fixes = dataclasses.replace(
            drive, data={k: v for k, v in drive.data.items() if k not in ("gnss_ve", "gnss_vn", "gnss_vu")}
        )
        cp = gnss.course_samples(fixes, speed, use_positions=True)
        corr_fix = yaw_rate_course_correlation(
            drive.t, drive["wz"], CourseSamples(cp.rows, cp.course, cp.speed, cp.sigma)
        )
        if corr_fix is not None and corr_fix < -0.5:
            raise InputError(
                drive.path,
                f"the course of the GNSS positions turns opposite to the yaw rate and to the "
                f"Doppler's (correlations {corr_fix:.2f}, {corr:.2f}): expected gnss_e, gnss_n "
                "east and north (ENU), as gnss_ve, gnss_vn are; are the positions in north-east "
                "order, or one of them negated?",
                column="gnss_e",
            )
    if corr is None or corr >= -0.5:
        return
    # the gyro or the GNSS frame: where the lateral accelerometer follows speed x wz tightly
    # (the IMU's own two axes agree), the course is the one turning the wrong way (east and
    # north swapped, as in a NED receiver's order, or one of them negated); a gyro mounted
    # upside down turns against the accelerometer too
    lateral = lateral_slope(drive)
    imu_agrees = lateral is not None and lateral[0] > 0.0 and lateral[1] >= MIN_CORRELATION
    steer = _steer_yaw_correlation(drive)
    columns = "gnss_ve, gnss_vn" if "gnss_ve" in drive else "gnss_e, gnss_n"
    if steer is not None and steer > 0.5:
        # the steering turns with the gyro: the course is the one turning the wrong way
        also = f", ay follows speed x wz ({lateral[1]:.2f})" if imu_agrees and lateral else ""
        raise InputError(
            drive.path,
            f"the GNSS course turns opposite to the yaw rate (correlation {corr:.2f}), while the "
            f"steering turns with it ({steer:.2f}{also}): expected {columns} east and north "
            "(ENU); are they in north-east (NED) order, or one of them negated?",
            column=columns.split(",")[0],
        )
    if imu_agrees and lateral:
        # the IMU's two axes agree with each other: both flipped (an IMU in SAE axes), or the
        # GNSS frame where no steering tells which
        raise InputError(
            drive.path,
            f"the yaw rate and ay turn opposite to the GNSS course (correlation {corr:.2f}; ay "
            f"follows speed x wz, {lateral[1]:.2f}"
            + (f"; the steering turns against the yaw rate, {steer:.2f}" if steer is not None else "")
            + "): expected wz > 0 and ay > 0 turning left (ISO 8855); is the IMU in SAE axes (y "
            "right, z down)"
            + ("?" if steer is not None else f", or the GNSS {columns} in north-east order?"),
            column="wz",
        )
    check_yaw_rate_sign(drive.t, drive["wz"], samples, drive.path)


def _steer_yaw_correlation(drive: Drive) -> float | None:
    """Correlation of the steering angle with the yaw rate over the drive's turns (faster than
    5 m/s, |w_z| above 0.05 rad/s, at least 5 s of them), or None without either."""
    from sideslip.signals import vehicle_speed

    if "steer" not in drive:
        return None
    steer = np.asarray(drive["steer"], dtype=float)
    wz = np.asarray(drive["wz"], dtype=float)
    with np.errstate(invalid="ignore"):
        rows = np.isfinite(steer) & np.isfinite(wz) & (vehicle_speed(drive) > 5.0) & (np.abs(wz) > 0.05)
    if rows.sum() < 10 or rows.sum() * drive.dt_median < 5.0:
        return None
    c = np.corrcoef(steer[rows], wz[rows])[0, 1]
    return float(c) if np.isfinite(c) else None


def check_method(method: str | Method, drive: Drive, vehicle: Vehicle, settings: Any = None) -> Any:
    """Every check :func:`run_method` makes before it runs ``method`` on ``drive``: its
    settings, its columns, the drive's units and axes (``sideslip.units_check``) and the
    vehicle file's parameters; raises the one-line InputError naming what is wrong.  Returns
    the settings resolved (an instance of the method's settings class, or None).  Callers that
    run several methods check them all first, so that a bad input stops the run before any
    method has run (contract section 5)."""
    method = get_method(method)
    if method.settings is None and settings is not None:
        raise InputError("settings", f"method '{method.name}' has no settings")
    if method.settings is not None:
        if settings is None:
            settings = method.default_settings()
        elif isinstance(settings, Mapping):
            settings = make_settings(method.settings, settings, f"settings: {method.name}")
        elif not isinstance(settings, method.settings):
            raise TypeError(
                f"settings for {method.name} must be {method.settings.__name__}, "
                f"not {type(settings).__name__}"
            )
    cols = missing_columns(method, drive)
    if cols:
        raise InputError(
            drive.path,
            f"method '{method.name}' needs this column, which is missing or empty",
            column=cols[0],
        )
    check_gyro_sign(drive)
    check_lateral_units(drive)
    check_tilt_rate_units(drive)
    check_longitudinal(drive)
    check_gnss_speed_units(drive)
    uses_steer = "steer" in columns_used(method, drive)
    check_lateral_axes(drive, uses_steer)
    if uses_steer:
        check_steer_units(drive, vehicle.lf + vehicle.lr)
    params = vehicle.missing(list(method.vehicle_params))
    if params:
        raise InputError(
            vehicle.source,
            f"parameter '{params[0]}' is needed by method '{method.name}' "
            "but the vehicle file does not give it",
        )
    return settings


def run_method(
    method: str | Method, drive: Drive, vehicle: Vehicle, settings: Any = None, checked: bool = False
) -> Estimate:
    """Run one method (by name or Method) after checking its needs (:func:`check_method`);
    raises InputError naming what is missing.  ``settings``: an instance of the method's
    settings class, a mapping of field -> value applied to its defaults, or None for the
    defaults.  ``checked``: :func:`check_method` has passed and ``settings`` is what it
    returned (the checks are not repeated)."""
    method = get_method(method)
    if not checked:
        settings = check_method(method, drive, vehicle, settings)
    moved_note = None
    # an IMU stamped late against the Doppler and the wheels is moved back by the lag the
    # drive decides (sideslip.imu_timing; race_lap with the IMU 50 ms late: fused 0.132 ->
    # 0.026 deg, kkf 0.748 -> 0.180)
    run_drive, imu_timing = drive, None
    if reads_gnss(method):  # the others' inputs keep their clocks (the fit costs 0.34 s/h)
        run_drive, imu_timing = drive_on_gnss_clock(drive, vehicle)
    timing = None
    if uses_gnss(method) and "gnss_ve" in drive:
        # a GNSS Doppler stamped late reads r x latency as sideslip in every turn: the
        # epochs are taken at their stamps less the latency the drive decides
        # (sideslip.doppler_timing; fused times the receiver itself)
        run_drive, timing = drive_on_receiver_time(run_drive, vehicle)
    if method.accelerometer != "own":
        # an IMU the vehicle file puts away from the CG reads omega' x l + omega x (omega x l)
        # more than the CG's specific force (an IMU 1.2 m ahead: obs_modified on urban_course
        # 0.113 -> 0.177 deg without the move)
        run_drive, moved_note = drive_at_cg(run_drive, vehicle, causal=method.accelerometer == "cg_causal")
    if method.settings is None:
        est = method.func(run_drive, vehicle)
    else:
        est = method.func(run_drive, vehicle, settings)
    del run_drive
    if moved_note is not None:
        est = Estimate(est.method, est.t, est.series, {**est.params, "accelerometer_at_cg": moved_note},
                       est.innovations)  # fmt: skip
    if timing is not None:
        series = dict(est.series)
        if (timing.latency_s > 0.0 or timing.early) and "beta_std" in series:
            # the epochs moved by a latency known to timing.sigma_s: a residual tau lags the
            # course by r tau, read as slip (cr_limit_ramp, 5 Hz Doppler 200 ms late, read
            # 0.195 +- 0.030 s: doppler_slip 75 % inside 2 sigma without this term); or the
            # Doppler reads early by timing.sigma_s against the IMU and the wheels both (a
            # whole bus stamped late, which sideslip.imu_timing leaves alone), not moved but
            # lagging the heading against the course the same way
            rate = series["r"] if "r" in series else np.nan_to_num(drive["wz"])
            series["beta_std"] = np.hypot(series["beta_std"], np.abs(rate) * timing.sigma_s)
        est = Estimate(est.method, est.t, series, {
            **est.params, "gnss_doppler_latency_applied_s": timing.latency_s,
            "gnss_doppler_latency_applied_note": timing.note,
        }, est.innovations)  # fmt: skip
    if imu_timing is not None:
        series = dict(est.series)
        imu_params = {**est.params, "imu_lag_applied_s": imu_timing.lag_s, "imu_lag_note": imu_timing.note}
        if imu_timing.lag_s > 0.0 and "beta_std" in series:
            # what remains of the lag lags the inputs against the course by r sigma
            rate = series["r"] if "r" in series else np.nan_to_num(drive["wz"])
            series["beta_std"] = np.hypot(series["beta_std"], np.abs(rate) * imu_timing.sigma_s)
        est = Estimate(est.method, est.t, series, imu_params, est.innovations)
    if est.method != method.name or (settings is not None and "settings" not in est.params):
        est_params = dict(est.params)
        if settings is not None:
            est_params.setdefault("settings", settings_dict(settings))
        est = Estimate(method.name, est.t, est.series, est_params, est.innovations)
    est = _with_input_health(method, drive, est)
    check_estimate(est, len(drive))
    if not np.array_equal(est.t, drive.t):
        raise RuntimeError(f"method {method.name}: estimate is not on the drive's time base")
    return est


def uses_gnss(method: Method) -> bool:
    """Whether ``method`` needs a GNSS column (then :func:`run_method` hands it the drive on
    the receiver's time, :func:`sideslip.doppler_timing.drive_on_receiver_time`)."""
    names = [c for need in method.columns for c in ((need,) if isinstance(need, str) else need)]
    return any(c.startswith("gnss_") for c in names)


def reads_gnss(method: Method) -> bool:
    """Whether ``method`` reads a GNSS column, as a need or where present (``optional``)."""
    return uses_gnss(method) or any(c.startswith("gnss_") for c in method.optional)


def columns_used(method: Method, drive: Drive) -> list[str]:
    """The drive columns behind ``method``'s requirements (first present alternative each)."""
    used = []
    for need in method.columns:
        if isinstance(need, str):
            if need in drive:
                used.append(need)
        else:
            alts = need
            present = [a for a in alts if a in drive]
            if set(alts) >= set(SPEED):
                used.extend(present)  # every wheel/CAN speed present feeds the speed signal
            elif present:
                used.append(present[0])
    return used


def _with_input_health(method: Method, drive: Drive, est: Estimate) -> Estimate:
    """Combine the method's own ``health`` with :func:`sideslip.input_health.input_health`
    (dropouts, clock jumps, implausible wheel speeds): the larger wins, per row."""
    from sideslip.input_health import input_health
    from sideslip.signals import wheel_speed

    used = columns_used(method, drive)
    speed = None
    if any(c in SPEED for c in used):
        speed = wheel_speed(drive)
        if speed is None and "v_can" in drive:
            speed = drive["v_can"]
    h_in = input_health(drive, used, speed)
    own = est.series.get("health")
    if own is None and not h_in.any():
        return est
    flagged_share = float(np.count_nonzero(h_in > 0) / max(h_in.size, 1))
    health = h_in if own is None else np.maximum(np.asarray(own, dtype=float), h_in, out=h_in)
    series = {**est.series, "health": health}
    params = dict(est.params)
    params["input_health"] = {
        "criterion": "inputs: dropouts of IMU/speed/steering, clock jumps, implausible wheel speeds",
        "flagged_share": flagged_share,
        "columns_checked": used,
    }
    return Estimate(est.method, est.t, series, params, est.innovations)
