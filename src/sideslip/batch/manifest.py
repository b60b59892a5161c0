"""Manifests: what a drive's outputs were computed from, so ``--resume`` can trust them.

Each drive's outputs (``<key>_est.parquet`` and ``<key>_est.params.json``) get a
``<key>_est.manifest.json``, written last and atomically: the input drive's SHA-256 (its
side-car metadata included), the vehicle's, the methods and the settings each ran with, the
sideslip version, each output's SHA-256, and the job's result (rows, metrics).  A drive is
complete when its manifest matches what the batch would compute now *and* every output still
hashes to what the manifest recorded; anything else (no manifest, an edited input, other
methods or settings, a truncated or replaced output) is computed again.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import asdict
from typing import Any

from sideslip.batch import storage

FORMAT = "sideslip-batch-manifest/1"
OUTPUT_SUFFIXES = ("_est.parquet", "_est.params.json")
MANIFEST_SUFFIX = "_est.manifest.json"


def drive_sha256(path: str) -> str:
    """SHA-256 of the drive file and, when there is one, its side-car ``.meta.json``."""
    h = hashlib.sha256(storage.sha256(path).encode())
    stem, _, _ = path.rpartition(".")
    side = f"{stem}.meta.json"
    if storage.exists(side):
        h.update(storage.sha256(side).encode())
    return h.hexdigest()


def vehicle_sha256(vehicle: Any) -> str:
    """SHA-256 of the vehicle's parameters (the values, not the file's formatting)."""
    text = json.dumps(asdict(vehicle), sort_keys=True, default=repr)
    return hashlib.sha256(text.encode()).hexdigest()


def fingerprint(
    drive_hash: str, vehicle_hash: str, methods: list[str], settings: dict[str, dict[str, Any]]
) -> dict[str, Any]:
    """What a drive's outputs depend on (compared field by field on resume)."""
    from sideslip import __version__

    return {
        "format": FORMAT,
        "drive_sha256": drive_hash,
        "vehicle_sha256": vehicle_hash,
        "methods": sorted(methods),
        "settings": json.loads(json.dumps(settings, sort_keys=True, default=repr)),
        "sideslip_version": __version__,
    }


def write(out_dir: str, key: str, fp: dict[str, Any], result: dict[str, Any]) -> str:
    """Hash the outputs of ``key`` and write its manifest (last, atomically); returns its path."""
    outputs = {
        key.rpartition("/")[2] + s: storage.sha256(storage.join(out_dir, key + s)) for s in OUTPUT_SUFFIXES
    }
    path = storage.join(out_dir, key + MANIFEST_SUFFIX)
    storage.write_text(path, json.dumps({**fp, "outputs": outputs, "result": result}, indent=1))
    return path


def complete(out_dir: str, key: str, fp: dict[str, Any]) -> dict[str, Any] | None:
    """The stored result when ``key``'s outputs are complete for ``fp``, else None."""
    path = storage.join(out_dir, key + MANIFEST_SUFFIX)
    if not storage.exists(path):
        return None
    try:
        stored = json.loads(storage.read_bytes(path))
    except (OSError, ValueError):
        return None
    if not isinstance(stored, dict) or any(stored.get(k) != v for k, v in fp.items()):
        return None
    folder = key.rpartition("/")[0]
    outputs = stored.get("outputs")
    if not isinstance(outputs, dict) or len(outputs) != len(OUTPUT_SUFFIXES):
        return None
    for name, digest in outputs.items():
        target = storage.join(out_dir, f"{folder}/{name}" if folder else name)
        if not storage.exists(target) or storage.sha256(target) != digest:
            return None
    result = stored.get("result")
    return result if isinstance(result, dict) else None
