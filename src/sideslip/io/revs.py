"""Stanford Revs text logs (one ASCII column per signal) to a drive.

Format: a lap folder of ``<signal>.txt`` files, one number per line, all on the time base of
``t.txt`` (s).  This is how the seed-002 authors ship the Ferrari 250 LM lap (Leanza, Reina,
Blanco-Claraco 2021, data from Stanford's Revs programme; repository
MBDS/sideslip-angle-vehicle-estimation, ``datasets/mat2txt.m`` cut the text files from a .mat
log).  Units and meanings are those of ``../shared/data/revs_250lm_20140222/DATA_NOTES.md``,
checked against the data:

====================  ==========  =========================================================
file                  unit        drive column
====================  ==========  =========================================================
``t.txt``             s           ``t``
``yawRate.txt``       rad/s       ``wz`` (the INS yaw rate, left positive) and ``ref_r``
``ayCG.txt``          m/s^2       ``ay`` (lateral acceleration at the CG)
``axCG.txt``          m/s^2       ``ax`` (optional file)
``vx.txt``            m/s         ``v_can`` (the speed input, as the paper uses it) and ``ref_vx``
``vy.txt``            m/s         ``ref_vy`` (ISO 8855: left positive)
``delta.txt``         rad         ``steer`` (road-wheel angle, mean of the front wheels)
``beta_true.txt``     rad         ``ref_beta`` (= atan2(vy, vx) to 3e-7 deg)
====================  ==========  =========================================================

``yawRateFilt.txt`` is in deg/s (mat2txt.m did not convert it) and is not used: ``yawRate``
is the raw INS rate.  The sensors are an INS's (cleaner than a production car's); there is no
GNSS, no wheel speed, no roll.  A folder holding exactly one lap folder is accepted too.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from sideslip.drive import Drive, drive_from_columns
from sideslip.errors import InputError

FloatArray = NDArray[np.float64]

# drive column -> source file (required files first)
REQUIRED: dict[str, str] = {
    "wz": "yawRate.txt",
    "ay": "ayCG.txt",
    "v_can": "vx.txt",
    "steer": "delta.txt",
    "ref_beta": "beta_true.txt",
    "ref_vx": "vx.txt",
    "ref_vy": "vy.txt",
    "ref_r": "yawRate.txt",
}
OPTIONAL: dict[str, str] = {"ax": "axCG.txt"}


def lap_folder(src: Path) -> Path:
    """The folder holding ``t.txt``: ``src`` itself or its only sub-folder that has one."""
    src = Path(src)
    if not src.is_dir():
        raise InputError(str(src), "expected a Revs lap folder of .txt columns (t.txt, yawRate.txt, "
                         "ayCG.txt, vx.txt, vy.txt, delta.txt, beta_true.txt)")
    if (src / "t.txt").is_file():
        return src
    laps = sorted(p for p in src.iterdir() if (p / "t.txt").is_file())
    if len(laps) != 1:
        found = ", ".join(p.name for p in laps) if laps else "none"
        raise InputError(str(src / "t.txt"), "file missing: expected a Revs lap folder with "
                         f"t.txt (or one sub-folder holding it; found {found})")
    return laps[0]


def read_column(path: Path, n_rows: int | None = None) -> FloatArray:
    """One ASCII column of numbers; InputError naming the file and row when it is not one."""
    if not path.is_file():
        raise InputError(str(path), "file missing: expected one number per line")
    try:
        lines = path.read_text(encoding="ascii").split()
    except (OSError, UnicodeDecodeError) as exc:
        raise InputError(str(path), f"unreadable ({exc.__class__.__name__}): expected ASCII "
                         "numbers, one per line") from None
    try:
        values = np.array(lines, dtype=float)
    except ValueError:
        for row, text in enumerate(lines):
            try:
                float(text)
            except ValueError:
                raise InputError(str(path), f"{text[:20]!r} is not a number: expected one number "
                                 "per line", row=row) from None
        raise  # pragma: no cover - np.array and float() disagree
    if values.ndim != 1 or values.size == 0:
        raise InputError(str(path), "empty: expected one number per line")
    if n_rows is not None and values.size != n_rows:
        raise InputError(str(path), f"{values.size} rows: expected {n_rows} (as many as t.txt)")
    bad = np.flatnonzero(~np.isfinite(values))
    if bad.size:
        raise InputError(str(path), f"{lines[bad[0]]!r}: expected a finite number",
                         row=int(bad[0]))
    return values


def convert_revs(src: Path) -> Drive:
    """A Revs lap folder (module docstring) as a validated drive with reference columns."""
    folder = lap_folder(Path(src))
    t = read_column(folder / "t.txt")
    cache: dict[str, FloatArray] = {}
    columns: dict[str, FloatArray] = {"t": t}
    for name, file in REQUIRED.items():
        if file not in cache:
            cache[file] = read_column(folder / file, t.size)
        columns[name] = cache[file]
    for name, file in OPTIONAL.items():
        if (folder / file).is_file():
            columns[name] = read_column(folder / file, t.size)
    meta = {
        "source": f"Stanford Revs text log {folder.name} (seed 002's lap format)",
        "speed_input": "v_can = INS vx (as seed 002 uses it)",
        "notes": "yawRateFilt.txt is in deg/s and is not used; no GNSS, wheel speeds or roll",
    }
    return drive_from_columns(columns, meta, path=str(folder))
