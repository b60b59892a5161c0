"""sideslip: vehicle sideslip, roll/bank, heading, bias and trajectory estimation from low-cost sensors.

Conventions (written once, used everywhere in the package)
-----------------------------------------------------------
* Units are SI; angles are radians unless a name ends in ``_deg``.
* Vehicle axes follow ISO 8855: x forward, y left, z up.  Roll ``phi`` is positive when the
  right side goes down, pitch ``theta`` positive nose down, yaw ``psi`` positive to the left.
* The navigation frame is local East-North-Up (ENU).  Yaw is measured from East,
  counter-clockwise positive, so a left turn has ``r = d(psi)/dt > 0``.
* Sideslip ``beta = atan2(v_y, v_x)`` of the body velocity at the centre of gravity (CG);
  course ``nu = psi + beta = atan2(v_n, v_e)``.
* Road bank uses the roll sign: a positive bank lowers the road's right edge.
* The accelerometer measures specific force.  With body roll ``phi`` (relative to the local
  horizontal, suspension roll plus road bank) its lateral channel reads
  ``a_y,m = a_y + g sin(phi)``, where ``a_y`` is the gravity-free lateral acceleration.
* Cornering stiffness ``cf``, ``cr`` is per axle (N/rad) unless a name says ``_per_tyre``.

Public API (imported lazily: ``import sideslip`` stays light)
--------------------------------------------------------------
``load_drive``, ``load_vehicle``, ``simulate_drive``, ``estimate``, ``evaluate``,
``method_names``, ``Drive``, ``Vehicle``, ``Estimate``, ``Estimates``, ``InputError``; see
:mod:`sideslip.api`.  ``sideslip.estimate`` and ``sideslip.evaluate`` are modules that can be
called as the functions of the same name (see :mod:`sideslip._callable`).
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

__version__ = "0.1.0"

_LAZY = {
    "load_drive": "sideslip.api",
    "load_vehicle": "sideslip.api",
    "simulate_drive": "sideslip.api",
    "estimate": "sideslip.estimate",  # the module, callable as sideslip.api.estimate
    "evaluate": "sideslip.evaluate",  # the module, callable as sideslip.api.evaluate
    "method_names": "sideslip.api",
    "Drive": "sideslip.drive",
    "Vehicle": "sideslip.vehicle",
    "Estimate": "sideslip.estimate",
    "Estimates": "sideslip.estimate",
    "InputError": "sideslip.errors",
}
__all__ = [
    "Drive", "Estimate", "Estimates", "InputError", "Vehicle", "__version__", "estimate", "evaluate",
    "load_drive", "load_vehicle", "method_names", "simulate_drive",
]  # fmt: skip

if TYPE_CHECKING:
    from sideslip.api import load_drive, load_vehicle, method_names, simulate_drive
    from sideslip.drive import Drive
    from sideslip.errors import InputError
    from sideslip.estimate import Estimate, Estimates
    from sideslip.vehicle import Vehicle


def __getattr__(name: str) -> Any:
    """Import the public names on first use (PEP 562), so ``import sideslip`` costs nothing."""
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'sideslip' has no attribute {name!r}")
    value = importlib.import_module(module)
    if module != f"sideslip.{name}":
        value = getattr(value, name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY))
