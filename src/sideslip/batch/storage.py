"""Where a fleet's files live: local paths or fsspec URLs (``s3://``, ``gcs://``, ``file://``...).

A batch reads drives and writes estimates through these few functions so the same job runs on
this machine or on a cluster's workers.  Local paths are made absolute (a worker on another
process resolves them the same way).  Every write is atomic: the bytes go to a temporary name
beside the target and are then renamed over it (``os.replace`` locally, ``fs.mv`` on a remote
store), so a reader never sees a half-written output and a job run twice leaves one file.
"""

from __future__ import annotations

import hashlib
import os
import tempfile
import uuid
from collections.abc import Callable
from pathlib import Path
from typing import Any

CHUNK = 1 << 20


def is_url(path: str) -> bool:
    """True for ``scheme://...`` (fsspec) paths; plain and Windows drive paths are local."""
    head, sep, _ = path.partition("://")
    return bool(sep) and len(head) > 1 and head.replace("+", "").replace("-", "").isalnum()


def normalise(path: str | os.PathLike[str]) -> str:
    """An absolute local path, or the URL as given (``file://`` URLs stay URLs)."""
    text = os.fspath(path)
    return text if is_url(text) else str(Path(text).expanduser().resolve())


def join(base: str, *parts: str) -> str:
    """``base``/``parts`` for a local path or a URL (always with ``/`` for URLs)."""
    if is_url(base):
        return "/".join([base.rstrip("/"), *(p.strip("/") for p in parts)])
    return str(Path(base).joinpath(*parts))


def _fs(path: str) -> tuple[Any, str]:
    from sideslip.errors import InputError

    try:
        import fsspec
    except ImportError:
        raise InputError(path, "a URL needs fsspec: pip install fsspec (and its driver)") from None
    try:
        fs, inner = fsspec.core.url_to_fs(path)
    except (ImportError, ValueError) as exc:
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise InputError(path, f"cannot open this URL: {first}") from None
    return fs, inner


def exists(path: str) -> bool:
    if not is_url(path):
        return Path(path).exists()
    fs, inner = _fs(path)
    return bool(fs.exists(inner))


def is_dir(path: str) -> bool:
    if not is_url(path):
        return Path(path).is_dir()
    fs, inner = _fs(path)
    return bool(fs.isdir(inner))


def makedirs(path: str) -> None:
    if not is_url(path):
        Path(path).mkdir(parents=True, exist_ok=True)
        return
    fs, inner = _fs(path)
    fs.makedirs(inner, exist_ok=True)


def read_bytes(path: str) -> bytes:
    if not is_url(path):
        return Path(path).read_bytes()
    fs, inner = _fs(path)
    with fs.open(inner, "rb") as fh:
        data: bytes = fh.read()
    return data


def sha256(path: str) -> str:
    """Hex SHA-256 of a file's bytes, streamed (no whole-file copy in memory)."""
    h = hashlib.sha256()
    if is_url(path):
        fs, inner = _fs(path)
        with fs.open(inner, "rb") as fh:
            while chunk := fh.read(CHUNK):
                h.update(chunk)
    else:
        with open(path, "rb") as fh:
            while chunk := fh.read(CHUNK):
                h.update(chunk)
    return h.hexdigest()


def write_atomic(path: str, write: Callable[[Path], object]) -> None:
    """``write(local_tmp)`` then move the result to ``path`` in one rename (local or remote)."""
    if not is_url(path):
        from sideslip.drive import _atomic_write

        _atomic_write(Path(path), write)
        return
    fs, inner = _fs(path)
    parent, _, name = inner.rpartition("/")
    with tempfile.TemporaryDirectory(prefix="sideslip-put-") as tmp:
        local = Path(tmp) / name
        write(local)
        remote_tmp = f"{parent}/.{name}.{uuid.uuid4().hex}.part"
        fs.makedirs(parent, exist_ok=True)
        fs.put_file(str(local), remote_tmp)
        try:
            fs.mv(remote_tmp, inner)
        except BaseException:
            fs.rm(remote_tmp)
            raise


def upload(local: Path, path: str) -> None:
    """Copy a local file to ``path`` atomically."""
    import shutil

    write_atomic(path, lambda tmp: shutil.copyfile(local, tmp))


def write_text(path: str, text: str) -> None:
    write_atomic(path, lambda tmp: tmp.write_text(text))


def local_copy(path: str, folder: Path) -> Path:
    """The file at ``path`` as a local file: itself when local, else a copy in ``folder`` (its
    side-car ``<stem>.meta.json`` comes along when there is one)."""
    if not is_url(path):
        return Path(path)
    fs, inner = _fs(path)
    name = inner.rpartition("/")[2]
    local = folder / name
    fs.get_file(inner, str(local))
    stem = name.rsplit(".", 1)[0]
    side = f"{inner.rpartition('/')[0]}/{stem}.meta.json"
    if fs.exists(side):
        fs.get_file(side, str(folder / f"{stem}.meta.json"))
    return local
