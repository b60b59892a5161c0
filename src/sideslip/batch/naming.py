"""Output names of a fleet's drives: short, readable, and never the same for two drives.

A drive's estimate is named after its file's stem (``logs/mon/drive.parquet`` ->
``drive_est.parquet``).  Where two drives share a stem (``mon/drive.parquet`` and
``tue/drive.parquet``) each takes as many of its parent folders as it needs to differ, as
sub-folders of the output folder (``mon/drive_est.parquet``, ``tue/drive_est.parquet``);
two files differing only by extension in one folder keep it in the name (``drive_csv``).
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Sequence

from sideslip.batch.storage import is_url


def _parts(path: str) -> list[str]:
    """Path components, the scheme and bucket of a URL included (``s3://b/x.csv`` -> s3, b, x.csv)."""
    if is_url(path):
        scheme, _, rest = path.partition("://")
        return [scheme, *[p for p in rest.split("/") if p]]
    return [p for p in path.replace("\\", "/").split("/") if p and p != "."]


def _safe(part: str) -> str:
    return "".join(c if c.isalnum() or c in "-_.=+@" else "_" for c in part) or "_"


def output_keys(drives: Sequence[str]) -> dict[str, str]:
    """Drive path -> output key (a relative name without suffix, ``/`` between folders).

    Keys are unique over distinct paths; a path listed twice maps to one key.
    """
    unique = list(dict.fromkeys(drives))
    parts = {d: _parts(d) for d in unique}
    stem = {d: _safe(p[-1].rsplit(".", 1)[0] if "." in p[-1] else p[-1]) for d, p in parts.items()}
    depth = dict.fromkeys(unique, 0)

    def key(d: str) -> str:
        parents = parts[d][:-1]
        k = depth[d]
        chosen = [_safe(p) for p in parents[len(parents) - k :]] if k else []
        return "/".join([*chosen, stem[d]])

    while True:
        counts = Counter(key(d) for d in unique)
        clashing = [d for d in unique if counts[key(d)] > 1]
        if not clashing:
            break
        grown = False
        for d in clashing:
            if depth[d] < len(parts[d]) - 1:
                depth[d] += 1
                grown = True
        if not grown:  # same folders all the way: the extension tells them apart
            for d in clashing:
                last = parts[d][-1]
                if "." in last and not stem[d].endswith("_" + _safe(last.rsplit(".", 1)[1])):
                    stem[d] = f"{stem[d]}_{_safe(last.rsplit('.', 1)[1])}"
                    grown = True
            if not grown:
                for i, d in enumerate(clashing):
                    stem[d] = f"{stem[d]}_{i + 1}"
    return {d: key(d) for d in unique}
