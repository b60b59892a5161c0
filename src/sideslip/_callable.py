"""Make a module callable, so ``sideslip.estimate(...)`` and ``sideslip.evaluate(...)`` work.

``sideslip.estimate`` and ``sideslip.evaluate`` are modules (the Estimate type, the metrics) and
also the public functions :func:`sideslip.api.estimate` and :func:`sideslip.api.evaluate`: a
module's attribute on its package is set by the import system whenever the module is first
imported, so a plain function of the same name on the package would be replaced.  Instead the
module itself is made callable and delegates to the function, which keeps every import form
(``import sideslip.estimate as m``, ``from sideslip.estimate import Estimate``) working.
"""

from __future__ import annotations

import importlib
import sys
import types
from typing import Any


def make_callable(module_name: str, target: str) -> None:
    """Calling module ``module_name`` calls ``target`` ("package.module:function")."""
    mod_path, func_name = target.split(":")

    class _CallableModule(types.ModuleType):
        def __call__(self, *args: Any, **kwargs: Any) -> Any:
            return getattr(importlib.import_module(mod_path), func_name)(*args, **kwargs)

    _CallableModule.__call__.__doc__ = f"Call :func:`{mod_path}.{func_name}`."
    sys.modules[module_name].__class__ = _CallableModule
