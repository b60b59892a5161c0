"""Method settings: typed, frozen dataclasses that a user reaches by name.

A method that has tuning registers its settings class (``register(..., settings=Cls)``).  The
class is a frozen dataclass whose fields carry their unit and meaning in the name or docstring
(``*_sigma`` a 1-sigma per sample, ``*_psd`` a density per sqrt(s)); ``__post_init__`` raises
``ValueError`` for a value out of range.  This module turns outside text into such objects:

* ``--set fg_batch.lateral_acceleration=7`` on the command line (:func:`parse_assignment`),
* a TOML file with one table per method (:func:`load_settings_file`)::

      [fg_batch]
      lateral_acceleration = 7.0
      preset = "paper"

and reports an unknown method, an unknown field or a bad value as one :class:`InputError` line.
"""

from __future__ import annotations

import dataclasses
import tomllib
import types
import typing
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from sideslip.errors import InputError


def settings_dict(settings: Any) -> dict[str, Any]:
    """The settings as a JSON-serialisable dict (for the estimate's params)."""
    if settings is None:
        return {}
    return {f.name: getattr(settings, f.name) for f in dataclasses.fields(settings)}


def _field_types(cls: type) -> dict[str, Any]:
    hints = typing.get_type_hints(cls)
    return {f.name: hints.get(f.name, Any) for f in dataclasses.fields(cls)}


def _coerce(value: Any, hint: Any, where: str) -> Any:
    """``value`` (from TOML or command-line text) as the field's type; InputError if it is not."""
    origin = typing.get_origin(hint)
    if origin is typing.Union or origin is types.UnionType:
        args = [a for a in typing.get_args(hint) if a is not type(None)]
        if value is None or (isinstance(value, str) and value.lower() == "none"):
            return None
        last: InputError | None = None
        for a in args:
            try:
                return _coerce(value, a, where)
            except InputError as exc:
                last = exc
        assert last is not None
        raise last
    if origin is typing.Literal:
        allowed = typing.get_args(hint)
        if value in allowed:
            return value
        raise InputError(where, f"{value!r}: expected one of {', '.join(map(repr, allowed))}")
    if hint is bool:
        if isinstance(value, bool):
            return value
        if isinstance(value, str) and value.lower() in ("true", "false", "1", "0", "yes", "no"):
            return value.lower() in ("true", "1", "yes")
        raise InputError(where, f"{value!r}: expected true or false")
    if hint is int:
        if isinstance(value, bool):
            raise InputError(where, f"{value!r}: expected an integer")
        try:
            as_float = float(value)
        except (TypeError, ValueError):
            raise InputError(where, f"{value!r}: expected an integer") from None
        if as_float != int(as_float):
            raise InputError(where, f"{value!r}: expected an integer")
        return int(as_float)
    if hint is float:
        if isinstance(value, bool):
            raise InputError(where, f"{value!r}: expected a number")
        try:
            return float(value)
        except (TypeError, ValueError):
            raise InputError(where, f"{value!r}: expected a number") from None
    if hint is str:
        return str(value)
    return value


def make_settings(cls: type, values: Mapping[str, Any], where: str, base: Any = None) -> Any:
    """An instance of the settings dataclass ``cls`` from ``base`` (default: the class's
    defaults) with ``values`` replaced; each problem is one InputError naming ``where``."""
    types_ = _field_types(cls)
    converted: dict[str, Any] = {}
    for key, raw in values.items():
        if key not in types_:
            raise InputError(where, f"unknown setting '{key}': expected one of {', '.join(types_)}")
        converted[key] = _coerce(raw, types_[key], f"{where}: setting '{key}'")
    try:
        start = base if base is not None else cls()
        return dataclasses.replace(start, **converted)
    except (ValueError, TypeError) as exc:
        raise InputError(where, str(exc)) from None


def parse_assignment(text: str) -> tuple[str, str, str]:
    """``"fg_batch.lateral_acceleration=7"`` -> ``("fg_batch", "lateral_acceleration", "7")``."""
    head, sep, value = text.partition("=")
    method, dot, field = head.strip().partition(".")
    if not sep or not dot or not method or not field:
        raise InputError("--set", f"'{text}': expected METHOD.FIELD=VALUE, e.g. fg_batch.window=10")
    return method, field.strip(), value.strip()


def load_settings_file(path: str | Path) -> dict[str, dict[str, Any]]:
    """A tuning TOML: one table per method name -> field -> value."""
    p = Path(path)
    try:
        data = tomllib.loads(p.read_text())
    except FileNotFoundError:
        raise InputError(str(p), "file not found: expected a settings TOML") from None
    except (OSError, UnicodeDecodeError, tomllib.TOMLDecodeError) as exc:
        raise InputError(str(p), f"unreadable settings TOML ({exc})") from None
    out: dict[str, dict[str, Any]] = {}
    for method, table in data.items():
        if not isinstance(table, dict):
            raise InputError(str(p), f"'{method}' must be a table [{method}] of settings")
        out[method] = dict(table)
    return out
