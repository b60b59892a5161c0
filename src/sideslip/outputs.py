"""Safe output writing (contract section 5: "nothing is written on failure").

Every file the toolkit writes goes through :func:`atomic_write`:

* a regular file (or a path not yet there) is written to a temporary file in the *target's*
  folder and renamed over the target, so a reader never sees half a file and a failure or an
  interrupt leaves the old file (or nothing) behind;
* a symbolic link is followed: the link's target is replaced atomically and the link stays a
  link (``--json /dev/stdout`` or a link into a shared folder keep working);
* a device, FIFO or socket (``/dev/stdout``, ``/dev/null``, a named pipe) is written directly —
  it cannot be renamed over, and it holds no earlier content to protect;
* ``-`` means standard output where a command supports it.

Writes inside :func:`output_group` become visible together when the group ends (the table and
its ``.params.json`` / ``.meta.json`` side-cars), or not at all.  :func:`check_outputs` runs
before any method: an output naming one of the command's inputs (also through a link or a hard
link), a folder where a file is expected (or the reverse) and a folder that cannot be written
are one :class:`InputError` line each.  :func:`install_signal_handlers` turns SIGINT, SIGTERM
and SIGHUP into :class:`Interrupted`, a ``KeyboardInterrupt``, so temporary files are removed
on the way out exactly as for Ctrl-C.

Creating a temporary file and recording it (and deleting it and forgetting it, and the final
renames) happen with signals held: :func:`_signals_held` blocks them in the calling thread and
also makes the Python-level handler defer them until the section ends.  Blocking alone is not
enough: the process has other threads (numpy's BLAS and pyarrow's pools), the kernel hands a
process-directed signal to one of those, and CPython then runs the handler in the main thread
at its next instruction, inside the section (a SIGTERM right after ``mkstemp`` left an
unrecorded ``.part`` file behind).
"""

from __future__ import annotations

import contextlib
import os
import shutil
import signal
import stat
import sys
import tempfile
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path
from types import FrameType
from typing import Any

from sideslip.errors import InputError

PathLike = str | os.PathLike[str]
Writer = Callable[[Path], Any]
STDOUT = "-"

_LIVE_TEMPS: set[str] = set()
_GROUP: list[list[tuple[str, str]]] = []  # stack of pending (temp, target) renames


class Interrupted(KeyboardInterrupt):
    """A termination signal (SIGTERM, SIGHUP) raised as an exception, so cleanup runs."""

    def __init__(self, signum: int) -> None:
        super().__init__(signal.Signals(signum).name)
        self.signum = signum


_HELD_SIGNALS = {signal.SIGINT, signal.SIGTERM, signal.SIGHUP}
_HOLD = [0]  # depth of nested _signals_held sections
_PENDING: list[int] = []  # signals that arrived while held, raised when the section ends


def _on_signal(signum: int, _frame: FrameType | None) -> None:
    if _HOLD[0]:
        _PENDING.append(signum)
        return
    raise Interrupted(signum)


def install_signal_handlers() -> None:
    """SIGINT, SIGTERM and SIGHUP raise :class:`Interrupted` (a ``KeyboardInterrupt``; exit
    status 128 + signal), deferred while a :func:`_signals_held` section runs.  A signal the
    process was started ignoring (``nohup``, a shell's background job) stays ignored."""
    for sig in (signal.SIGINT, signal.SIGTERM, signal.SIGHUP):
        with contextlib.suppress(ValueError, OSError):  # not the main thread / not supported
            if signal.getsignal(sig) is not signal.SIG_IGN:  # nohup, a background job: kept
                signal.signal(sig, _on_signal)


@contextlib.contextmanager
def _signals_held() -> Iterator[None]:
    """Run the block with SIGINT, SIGTERM and SIGHUP held (module docstring); one that came in
    the meantime is raised as :class:`Interrupted` when the outermost section ends."""
    old = signal.pthread_sigmask(signal.SIG_BLOCK, _HELD_SIGNALS)
    _HOLD[0] += 1
    try:
        yield
    finally:
        _HOLD[0] -= 1
        signal.pthread_sigmask(signal.SIG_SETMASK, old)
        if not _HOLD[0] and _PENDING:
            signum = _PENDING[0]
            _PENDING.clear()
            raise Interrupted(signum)


def remove_temps() -> None:
    """Delete every temporary file still open (the last line of defence on exit)."""
    for tmp in list(_LIVE_TEMPS):
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        _LIVE_TEMPS.discard(tmp)


def is_special(path: PathLike) -> bool:
    """True for ``-`` and for an existing device, FIFO or socket (written directly)."""
    if os.fspath(path) == STDOUT:
        return True
    try:
        mode = os.stat(path).st_mode
    except OSError:
        return False
    return not (stat.S_ISREG(mode) or stat.S_ISDIR(mode))


def _mode_for(real: str) -> int:
    try:
        return stat.S_IMODE(os.stat(real).st_mode)
    except OSError:
        umask = os.umask(0)
        os.umask(umask)
        return 0o666 & ~umask


def _write_stdout(write: Writer) -> None:
    fd, tmp = _registered_temp(tempfile.gettempdir(), ".sideslip-stdout.")
    os.close(fd)
    try:
        write(Path(tmp))
        sys.stdout.flush()
        with open(tmp, "rb") as src:
            shutil.copyfileobj(src, sys.stdout.buffer)
        sys.stdout.buffer.flush()
    finally:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        _LIVE_TEMPS.discard(tmp)


def _registered_temp(folder: str, prefix: str) -> tuple[int, str]:
    """A temporary file in ``folder``, registered for clean-up before any signal can land:
    a SIGINT/SIGTERM between creating the file and recording it would leave it behind."""
    with _signals_held():
        fd, tmp = tempfile.mkstemp(dir=folder, prefix=prefix, suffix=".part")
        _LIVE_TEMPS.add(tmp)
    return fd, tmp


def _drop_temp(tmp: str) -> None:
    """Delete a temporary file and forget it, with signals held (a second signal during the
    clean-up of the first would otherwise leave the file behind, unregistered)."""
    with _signals_held(), contextlib.suppress(OSError):
        os.unlink(tmp)
    _LIVE_TEMPS.discard(tmp)


def atomic_write(path: PathLike, write: Writer) -> None:
    """Write ``path`` through ``write(tmp_path)`` so it is never half-written (module docstring).

    An operating-system failure while writing is one :class:`InputError` line naming the path.
    """
    name = os.fspath(path)
    try:
        if name == STDOUT:
            _write_stdout(write)
            return
        if is_special(name):
            write(Path(name))
            return
        real = os.path.realpath(name)  # through symbolic links, to the file to replace
        folder = os.path.dirname(real)
        os.makedirs(folder, exist_ok=True)
        fd, tmp = _registered_temp(folder, f".{os.path.basename(real)}.")
    except OSError as exc:
        raise InputError(name, f"cannot write ({exc.strerror or exc}): expected a writable path") from None
    grouped = False
    try:
        os.close(fd)
        write(Path(tmp))
        os.chmod(tmp, _mode_for(real))
        if _GROUP:
            _GROUP[-1].append((tmp, real))
            grouped = True
            return
        os.replace(tmp, real)
    except OSError as exc:
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        raise InputError(name, f"cannot write ({exc.strerror or exc}): expected a writable path") from None
    except BaseException:
        _drop_temp(tmp)
        raise
    finally:
        if not grouped and not os.path.lexists(tmp):  # else remove_temps still knows it
            _LIVE_TEMPS.discard(tmp)


@contextlib.contextmanager
def output_group() -> Iterator[None]:
    """Files written inside appear together at the end (renamed with signals held), or none."""
    if _GROUP:  # nested: the outer group commits
        yield
        return
    pending: list[tuple[str, str]] = []
    _GROUP.append(pending)
    try:
        yield
        with _signals_held():
            for tmp, real in pending:
                os.replace(tmp, real)
                _LIVE_TEMPS.discard(tmp)
    finally:
        _GROUP.pop()
        for tmp, _ in pending:
            if tmp in _LIVE_TEMPS:
                with contextlib.suppress(OSError):
                    os.unlink(tmp)
                _LIVE_TEMPS.discard(tmp)


# ------------------------------------------------------------------------------------------
# checks before anything runs
# ------------------------------------------------------------------------------------------
def _first_existing(path: str) -> str:
    cur = path
    while not os.path.lexists(cur):
        parent = os.path.dirname(cur)
        if parent == cur:
            break
        cur = parent
    return cur


def _check_folder_writable(shown: str, folder: str) -> None:
    base = _first_existing(folder)
    if not os.path.isdir(base):
        raise InputError(shown, f"{base} is a file, not a folder: expected a path in a writable folder")
    try:
        with _signals_held():  # never left behind
            fd, probe = tempfile.mkstemp(dir=base, prefix=".sideslip-probe.")
            os.close(fd)
            os.unlink(probe)
    except OSError as exc:
        raise InputError(shown, f"cannot write in {base} ({exc.strerror or exc}): expected a writable "
                         "folder") from None


def check_writable(path: PathLike, *, folder: bool = False) -> None:
    """Raise one InputError line unless ``path`` can be written (a file, or with ``folder``, a
    folder for several outputs).  Nothing is created."""
    name = os.fspath(path)
    if name == STDOUT:
        if folder:
            raise InputError(name, "expected a folder, not standard output")
        return
    if os.path.isdir(name):
        if not folder:
            raise InputError(name, "is a folder: expected a file name")
        _check_folder_writable(name, name)
        return
    if folder:
        if os.path.exists(name):
            raise InputError(name, "is a file: expected a folder for the outputs")
        _check_folder_writable(name, os.path.realpath(name))
        return
    if is_special(name):
        if not os.access(name, os.W_OK):
            raise InputError(name, "cannot write to this device: expected a writable path")
        return
    _check_folder_writable(name, os.path.dirname(os.path.realpath(name)))


def _same_file(a: str, b: str) -> bool:
    try:
        return os.path.samefile(a, b)
    except OSError:
        return os.path.realpath(a) == os.path.realpath(b)


def check_outputs(
    outputs: Iterable[PathLike | None],
    inputs: Iterable[PathLike | None] = (),
    *,
    folders: Iterable[PathLike | None] = (),
) -> None:
    """Before anything runs: every output writable and none of them one of the inputs.

    ``outputs`` are files, ``folders`` are output folders, ``inputs`` files or folders the
    command reads (links and hard links resolved).  Raises one :class:`InputError` line.
    """
    ins = [os.fspath(p) for p in inputs if p is not None and os.path.exists(p)]
    for out in folders:
        if out is not None:
            check_writable(out, folder=True)
    for out in outputs:
        if out is None:
            continue
        name = os.fspath(out)
        if name == STDOUT or (is_special(name) and not os.path.isfile(name)):
            check_writable(name)
            continue
        for src in ins:
            if _same_file(name, src):
                raise InputError(name, f"is the input {src}: expected another output name (writing "
                                 "it would replace the input)")
        check_writable(name)


def table_outputs(path: PathLike) -> list[Path]:
    """The files a table write creates: the table and, for CSV, its ``.meta.json`` side-car.

    A name that is no table (not .csv/.parquet) is an InputError here, before anything runs.
    """
    from sideslip.tables import meta_path

    p = Path(path)
    if p.suffix.lower() not in (".csv", ".parquet", ".pq"):
        raise InputError(str(path), "expected an output path ending in .csv or .parquet")
    return [p, meta_path(p)] if p.suffix.lower() == ".csv" else [p]


def estimate_outputs(path: PathLike) -> list[Path]:
    """The files ``sideslip estimate --out`` creates: the table (+ side-car) and ``.params.json``."""
    from sideslip.estimate import params_path

    return [*table_outputs(path), params_path(Path(path))]
