"""Decoding raw CAN frames with a DBC file (cantools), for the channels a map names.

A logger stores frames as (time, arbitration id, payload).  Payloads arrive in several shapes:
numpy byte strings (``S8``: numpy strips trailing zero bytes, so they are padded back to the
message length here), n x 8 ``uint8`` arrays (asammdf byte-array channels), Python ``bytes``,
or hexadecimal text (CSV: ``"0A1BFF..."``, optional spaces or ``0x``).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from sideslip.errors import InputError

FloatArray = NDArray[np.float64]


def load_dbc(path: str | Path) -> Any:
    """Load a DBC database; unreadable or invalid files raise one InputError line."""
    import cantools

    try:
        return cantools.database.load_file(str(path), database_format="dbc")
    except OSError as exc:
        raise InputError(str(path), f"cannot read the DBC file ({exc.strerror})") from None
    except Exception as exc:  # cantools raises parser-specific errors
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else type(exc).__name__
        raise InputError(str(path), f"not a valid DBC file ({first})") from None


def payload_bytes(item: Any, length: int) -> bytes:
    """One frame's payload as ``length`` bytes (zero-padded; see the module docstring)."""
    if isinstance(item, np.ndarray):
        raw = item.astype(np.uint8).tobytes()
    elif isinstance(item, bytes | bytearray | np.bytes_):
        raw = bytes(item)
    elif isinstance(item, str):
        text = item.strip().replace(" ", "")
        if text.lower().startswith("0x"):
            text = text[2:]
        raw = bytes.fromhex(text)
    else:
        raise ValueError(f"payload {item!r} is neither bytes nor hex text")
    return raw[:length].ljust(length, b"\x00")


def decode_signal(
    db: Any,
    message: str,
    signal: str,
    t: FloatArray,
    ids: NDArray[Any],
    payloads: NDArray[Any],
    *,
    source: str,
    column: str,
) -> tuple[FloatArray, FloatArray]:
    """The physical values and times of ``message.signal`` (see :func:`decode_signal_rows`)."""
    t_sig, values, _ = decode_signal_rows(db, message, signal, t, ids, payloads, source=source,
                                          column=column)
    return t_sig, values


def decode_signal_rows(
    db: Any,
    message: str,
    signal: str,
    t: FloatArray,
    ids: NDArray[Any],
    payloads: NDArray[Any],
    *,
    source: str,
    column: str,
) -> tuple[FloatArray, FloatArray, NDArray[np.intp]]:
    """The physical values (DBC scaling, DBC unit) of ``message.signal``, their times and the
    indices (from 0) of the frames they came from.

    Frames whose id is not the message's are skipped; extended ids are compared without the
    extended-frame flag.  A message or signal the DBC lacks, or a payload that cannot be
    decoded, raises InputError naming ``source`` (the map) and ``column``.
    """
    try:
        msg = db.get_message_by_name(message)
    except KeyError:
        names = [m.name for m in db.messages]
        raise InputError(source, f"DBC message {message!r} not found: expected one of "
                         + ", ".join(names[:12]), column=column) from None
    if signal not in [s.name for s in msg.signals]:
        raise InputError(source, f"DBC signal {signal!r} not in message {message!r}: expected "
                         "one of " + ", ".join(s.name for s in msg.signals), column=column)
    id_values = np.empty(len(ids), dtype=np.int64)
    for n, i in enumerate(np.asarray(ids).tolist()):
        try:
            id_values[n] = int(i, 16) if isinstance(i, str) else int(i)
        except (ValueError, TypeError, OverflowError):
            raise InputError(source, f"frame {n + 1}: arbitration id {str(i)[:30]!r}: expected an "
                             "integer or hex text", column=column) from None
    rows = np.flatnonzero((id_values & 0x1FFFFFFF) == msg.frame_id)
    values = np.empty(rows.size)
    for j, k in enumerate(rows):
        try:
            data = payload_bytes(payloads[k], msg.length)
            decoded = msg.decode(data, decode_choices=False, scaling=True)
        except (ValueError, TypeError) as exc:
            raise InputError(source, f"frame {k + 1} of {message!r} cannot be decoded ({exc}): "
                             "expected a payload as bytes or hex text", column=column) from None
        except Exception as exc:  # cantools DecodeError and friends
            raise InputError(source, f"frame {k + 1} of {message!r} cannot be decoded ({exc})",
                             column=column) from None
        values[j] = float(decoded[signal])
    return np.asarray(t, dtype=float)[rows], values, rows
