"""Toleranced fingerprints of simulated drives (a helper of the simulator's regression tests).

The refactors of the simulator (named model parameters, the split of scenarios.py) were first
guarded by sha256 digests of every array, recorded on one machine.  Digests are not portable:
numpy's and libm's vectorised sin/cos/exp differ in the last bit between CPUs (on an AMD EPYC
machine 11 of the 16 recorded digests differed although ``truth.e[-1]`` matched exactly), and a
closed-loop driver carries such bits through the drive.  A fingerprint keeps, per array, its
NaN-ignoring sum, sum of magnitudes and NaN count, and per other value its repr (exact): any
change of the model moves a sum by far more than 1e-7 of its magnitudes, a CPU's last bits by
far less.

Record (only when a change of the simulated drives is intended, and say so in the commit):
``.venv/bin/python -m tests.simulate.fingerprints``.
"""

from __future__ import annotations

import json
from dataclasses import fields, is_dataclass
from pathlib import Path
from typing import Any

import numpy as np

RECORDING = Path(__file__).resolve().parents[1] / "data" / "sim_fingerprints.json"
RTOL = 1e-7  # of the array's sum of magnitudes (see the module docstring)


def fingerprint(obj: Any, prefix: str = "", out: dict[str, Any] | None = None) -> dict[str, Any]:
    """Flat ``{path: [sum, sum_abs, n_nan] or repr}`` of a dataclass's fields, nested ones field
    by field; callables (a scenario's builder) are skipped."""
    out = {} if out is None else out
    for f in fields(obj):
        value = getattr(obj, f.name)
        key = prefix + f.name
        if isinstance(value, np.ndarray):
            out[key] = array_fingerprint(value)
        elif is_dataclass(value):
            fingerprint(value, key + ".", out)
        elif not callable(value):
            out[key] = repr(value)
    return out


def array_fingerprint(value: np.ndarray) -> list[float]:
    a = np.asarray(value, dtype=np.float64)
    return [float(np.nansum(a)), float(np.nansum(np.abs(a))), float(np.isnan(a).sum())]


def assert_matches(actual: dict[str, Any], recorded: dict[str, Any]) -> None:
    """Every recorded entry present and equal: reprs exactly, array sums within RTOL."""
    assert sorted(actual) == sorted(recorded), set(actual) ^ set(recorded)
    for key, want in recorded.items():
        got = actual[key]
        if isinstance(want, str):
            assert got == want, (key, got, want)
            continue
        s, sa, nan = got
        ws, wsa, wnan = want
        assert nan == wnan, (key, "NaN count", nan, wnan)
        tol = RTOL * max(wsa, 1e-300)
        assert abs(sa - wsa) <= tol and abs(s - ws) <= tol, (key, got, want)


def load() -> dict[str, dict[str, Any]]:
    return json.loads(RECORDING.read_text())


def _record() -> None:
    from sideslip.simulate.scenarios import SCENARIOS
    from tests.simulate.test_scenarios import split_fingerprint
    from tests.simulate.test_vehicle_model import TRUTH_DURATIONS, truth_fingerprint

    rec: dict[str, dict[str, Any]] = {}
    for name in sorted(SCENARIOS):
        rec[f"split/{name}"] = split_fingerprint(name)
    for name, duration in sorted(TRUTH_DURATIONS.items()):
        rec[f"truth/{name}"] = truth_fingerprint(name, duration)
    RECORDING.write_text(json.dumps(rec, indent=1, sort_keys=True) + "\n")
    print(f"wrote {RECORDING} ({len(rec)} drives)")


if __name__ == "__main__":
    _record()
