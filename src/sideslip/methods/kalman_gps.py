"""Seed 001 (Bevly-style GPS/INS Kalman filters): index of the family.

The filters live in one module each; this module only gathers their public names so that
``from sideslip.methods import kalman_gps`` keeps working:

* :mod:`sideslip.methods.kkf` -- ``kkf``, the kinematic Kalman filter (eqs 4, 6);
* :mod:`sideslip.methods.mkf` -- ``mkf``, the model-based Kalman filter (eqs 1-3, 5);
* :mod:`sideslip.methods.mkf_adaptive` -- ``mkf_adaptive`` (sec. VI);
* :mod:`sideslip.models.mkf_model` -- the MKF's model, discretisation table and Table I;
* :mod:`sideslip.gnss` -- the GNSS course they read.
"""

from __future__ import annotations

from sideslip.methods.kkf import KkfResult, KkfSettings, kkf, run_kkf, straight_flags
from sideslip.methods.mkf import (
    MkfProblem,
    MkfResult,
    MkfSettings,
    channel_diagnostics,
    mkf,
    mkf_problem,
    residual_diagnostics,
    run_mkf,
    run_mkf_problem,
)
from sideslip.methods.mkf_adaptive import (
    identify_cornering_stiffness,
    identify_from_kkf,
    mkf_adaptive,
)
from sideslip.models.mkf_model import (
    TABLE_I_PAPER,
    MkfNoise,
    mkf_continuous,
    table_one,
    table_one_model,
)

__all__ = [
    "TABLE_I_PAPER", "KkfResult", "KkfSettings", "MkfNoise", "MkfProblem", "MkfResult",
    "MkfSettings", "channel_diagnostics", "identify_cornering_stiffness", "identify_from_kkf",
    "kkf", "mkf", "mkf_adaptive", "mkf_continuous", "mkf_problem", "residual_diagnostics",
    "run_kkf", "run_mkf", "run_mkf_problem", "straight_flags", "table_one", "table_one_model",
]  # fmt: skip
