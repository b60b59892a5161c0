"""Settings of the seed-002 factor graph (:mod:`sideslip.methods.factor_graph`): the factor
sigmas, the presets they come from, and the low-speed, time-gap and consistency options.

Leanza, Reina, Blanco-Claraco (2021), "A factor graph-based approach to vehicle sideslip
angle estimation" (seed 002): the "paper" preset is the authors' published sigmas.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any, Literal

from sideslip.methods.fg_tuning import PRESETS, SIGMA_FIELDS

Preset = Literal["auto", "paper", "physics"]


@dataclass(frozen=True)
class FactorGraphSettings:
    """Sigmas (1-sigma of each factor's residual) and options of the seed-002 graph.

    The four sigmas come from ``preset`` unless set explicitly (an explicit value overrides
    the preset):

    * ``"auto"`` (default): ``lateral_acceleration`` and ``model_beta`` identified from the
      drive (:mod:`sideslip.methods.fg_tuning`: least error of the gyro predicted 0.3 s ahead),
      ``yaw_rate`` and ``model_yaw_rate`` from ``"physics"``;
    * ``"paper"``: the seed-002 authors' values (beta dynamic 4e-3, yaw-rate dynamic 0.9e-2,
      yaw-rate observation 1e-2, lateral acceleration 7; their code's defaults);
    * ``"physics"``: the fixed values argued below (this package's earlier default).

    Attributes
    ----------
    preset : "auto", "paper" or "physics" (above).
    yaw_rate : rad/s.  Yaw-rate factor r_k = wz_k: MEMS gyro white noise (~0.005 rad/s at
        100 Hz) plus an uncompensated bias of the same order; physics 0.01.
    lateral_acceleration : m/s^2.  a_y factor: accelerometer noise (~0.05 m/s^2) is small
        against the linear-tyre model error near the grip limit (~0.5 m/s^2 at 0.6 g with
        tyres 10 % past linear) and the suspension-roll term (~5 % of a_y); physics 0.5.
    model_beta : rad per ``reference_dt`` step.  beta dynamic factor: an error of 1 m/s^2 in
        the modelled tyre force per mass at 10 m/s is 0.1 rad/s of beta rate, 0.001 rad/step.
    model_yaw_rate : rad/s per ``reference_dt`` step.  r dynamic factor: a yaw-moment error of
        ~1000 N m on Iz ~ 1000 kg m^2 is 1 rad/s^2, 0.01 rad/s per step.
    prior_beta : rad.  Prior on beta_0 = 0: drives start near straight running; 3 deg.
    prior_yaw_rate : rad/s.  Prior on r_0 = 0; the first gyro sample overrides it.
    reference_dt : s.  Step at which the model sigmas are quoted (sigma ~ sqrt(dt)).
    speed_gate : m/s.  Below it (and reversing) the low-speed handling of the module docstring.
    low_speed_beta : rad.  Sigma of the low-speed kinematic pseudo-measurement on beta.
    low_speed_inflation : factor on the model sigmas below the speed gate.
    window : samples.  fg_lag's window: the dynamic steps after the prior block (paper: 5).
    max_step : s.  A time step longer than this (a gap in the recording) carries no model
        information: the dynamic factor across it becomes a fresh prior (restart).
    consistency : inflate the 1-sigma where the windowed NIS of the factors' residuals exceeds
        its chi^2 bound (:mod:`sideslip.filters.consistency`), and report ``health``.
    zero_gyro : subtract the drive's own gyro zero from the yaw-rate factors (the bias of its
        GNSS course windows and standstill, else of its rear wheel speeds,
        :func:`sideslip.calibrate.sensors.drive_gyro_bias`,
        where more than 2 sigma from 0: :func:`~sideslip.calibrate.sensors.subtracted_zero`).
        The paper's gyro is a calibrated INS; a raw MEMS gyro's bias is read as yaw by the
        model (the comma2k19 phone's -3.9 deg/s: kf_linear 0.170 -> 0.093 deg, fg_lag 0.122 ->
        0.093).  False: the samples as recorded.
    zero_steer : subtract the drive's own steering offset from the steer (the intercept of
        calibrate's steering relation alone, :func:`sideslip.calibrate.steer_zero.drive_steer_offset`,
        where more than 2 sigma from 0).  The graph reads an offset d0 as a front-axle force
        c_f d0, a sideslip offset on every row (the simulator's 0.1 deg road-wheel offset:
        mean beta RMSE over the 16 scenarios, seed 0, right file, 0.255 -> 0.244 deg; demo
        0.084 -> 0.037).  False: the steer as recorded.
    stiffness_rel_sigma : 1-sigma relative error of the vehicle file's cornering stiffness,
        added to beta's variance as (stiffness_rel_sigma x the larger axle slip angle)^2.  A stiffness
        scaled by s moves the slip angle inferred from a force by (1 - 1/s) of itself, the same
        for the whole graph, so neither the innovations nor any other test on the drive can see
        it (measured: a file 30 % low leaves the windowed NIS inside its bound).  Users' files
        are 20-35 % off (nominal tyre data against the effective axle stiffness): 0.3 makes a
        file 30 % off a 1-sigma error.  0 trusts the file.
    limit_rel_sigma : 1-sigma relative error of the *linear* tyre relation where the drive
        rejects the model (``health``, 0 ... 1), combined with stiffness_rel_sigma as
        hypot(stiffness_rel_sigma, health x limit_rel_sigma) on the same slip angle.  Past the
        linear range an axle's slip for a given force exceeds the linear one F / C by the factor
        3 (1 - (1 - u)^(1/3)) / u at a friction use u = |F| / (mu F_z) (brush model, Pacejka,
        *Tire and Vehicle Dynamics*, 3rd ed. 2012, sec. 3.2.2: F / (mu F_z) = 1 - (1 - x)^3 with
        x = C tan(alpha) / (3 mu F_z)): 1.24 at u = 0.5, 1.56 at 0.8, 1.79 at 0.9.  Neither mu
        nor u is known to the graph, so 0.5 makes an axle at 80 % of its friction a 1-sigma
        error and one at 95 % (factor 2.0) a 2-sigma one.  Measured (compare_methods.md's
        CommonRoad slalom on mu 0.6, rear axle saturating, right file, seeds 0 / 1 / 3): share
        of errors inside 2 sigma 0.86 / 0.87 / 0.86 without the term, 1.00 / 1.00 / 0.98 with it;
        0.3: 0.95 / 0.96 / 0.95.  0 turns it off.
    accel_offset_sigma : m/s^2, 1-sigma of a lateral accelerometer offset (a consumer MEMS
        turn-on bias, 0.15, and g times a 1 deg mounting roll, 0.17; the same value as
        :class:`~sideslip.methods.fused_settings.FusedSettings`).  The a_y factor reads it as
        tyre force, a sideslip offset of accel_offset_sigma x m / (C_f + C_r) (the inverse of
        d a_y / d beta in the paper's a_y row) that no test on the drive separates from a slip; added to
        beta's variance (straights of the CommonRoad slalom: errors of 0.08-0.11 deg against
        a 1-sigma of 0.04 deg without it).  0 turns it off.
    """

    preset: Preset = "auto"
    yaw_rate: float | None = None
    lateral_acceleration: float | None = None
    model_beta: float | None = None
    model_yaw_rate: float | None = None
    prior_beta: float = 0.05
    prior_yaw_rate: float = 0.05
    reference_dt: float = 0.01
    speed_gate: float = 3.0
    low_speed_beta: float = 0.02
    low_speed_inflation: float = 10.0
    window: int = 5
    max_step: float = 0.25
    consistency: bool = True
    zero_gyro: bool = True
    zero_steer: bool = True
    stiffness_rel_sigma: float = 0.3
    limit_rel_sigma: float = 0.5
    accel_offset_sigma: float = 0.25

    def __post_init__(self) -> None:
        if self.preset not in ("auto", *PRESETS):
            raise ValueError(
                f"FactorGraphSettings.preset = {self.preset!r}: expected 'auto', "
                + ", ".join(repr(p) for p in PRESETS)
            )
        for name in (
            *SIGMA_FIELDS, "prior_beta", "prior_yaw_rate", "reference_dt", "speed_gate",
            "low_speed_beta", "low_speed_inflation", "max_step",
        ):  # fmt: skip
            value = getattr(self, name)
            if value is None and name in SIGMA_FIELDS:
                continue
            if isinstance(value, bool) or not (
                isinstance(value, int | float) and math.isfinite(value) and value > 0
            ):
                raise ValueError(f"FactorGraphSettings.{name} = {value!r}: expected a number > 0")
        if not (math.isfinite(self.stiffness_rel_sigma) and 0 <= self.stiffness_rel_sigma < 1):
            raise ValueError(
                f"FactorGraphSettings.stiffness_rel_sigma = {self.stiffness_rel_sigma!r}: "
                "expected a number in [0, 1)"
            )
        for name in ("limit_rel_sigma", "accel_offset_sigma"):
            value = getattr(self, name)
            if isinstance(value, bool) or not (
                isinstance(value, int | float) and math.isfinite(value) and value >= 0
            ):
                raise ValueError(f"FactorGraphSettings.{name} = {value!r}: expected a number >= 0")
        if int(self.window) != self.window or self.window < 0:
            raise ValueError(
                f"FactorGraphSettings.window = {self.window!r}: expected an integer >= 0"
            )

    def fixed_sigmas(self) -> dict[str, float | None]:
        """Each sigma as set or given by a named preset; None where "auto" identifies it."""
        table = PRESETS.get(self.preset, {})
        return {k: getattr(self, k) if getattr(self, k) is not None else table.get(k)
                for k in SIGMA_FIELDS}  # fmt: skip

    def with_sigmas(self, sigmas: dict[str, float]) -> FactorGraphSettings:
        """These settings with all four sigmas given."""
        changes: dict[str, Any] = {k: float(sigmas[k]) for k in SIGMA_FIELDS}
        return replace(self, **changes)

    def sigma(self, name: str) -> float:
        """A sigma of resolved settings (:meth:`with_sigmas`); ValueError if still unset."""
        value = getattr(self, name)
        if value is None:
            raise ValueError(f"FactorGraphSettings.{name} is not resolved (preset 'auto')")
        return float(value)


DEFAULT_SETTINGS = FactorGraphSettings()
