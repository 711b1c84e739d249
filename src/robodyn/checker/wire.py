"""The formula process's wire: JSON headers with raw float64 arrays, never pickles.

Nothing a formula's process sends can run code in robodyn: a message is a length prefix, a JSON
header (which names its arrays and their shapes) and the arrays' little-endian float64 bytes.
"""

from __future__ import annotations

import json
import math
import struct
from collections.abc import Mapping
from typing import IO, Any

import numpy as np

from robodyn.kinds.formula import Array

MAX_MESSAGE = 2**30  # [bytes] a reply larger than this is refused unread

_FRAME = struct.Struct("<QQ")  # header length, body length


def encode(header: Mapping[str, Any], arrays: Mapping[str, Array] | None = None) -> bytes:
    """One message: JSON ``header`` and float64 ``arrays`` (their names and shapes go in the header)."""
    arrays = arrays or {}
    blobs = [np.ascontiguousarray(a, dtype="<f8") for a in arrays.values()]
    head = json.dumps({**header, "arrays": [[n, list(b.shape)] for n, b in zip(arrays, blobs, strict=True)]}).encode()
    body = b"".join(b.tobytes() for b in blobs)
    return _FRAME.pack(len(head), len(body)) + head + body


def read_message(stream: IO[bytes]) -> tuple[dict[str, Any], dict[str, Array]] | None:
    """The next message on ``stream``, None at its end; ValueError if it is not one robodyn wrote."""
    prefix = _read_exactly(stream, _FRAME.size)
    if prefix is None:
        return None
    n_head, n_body = _FRAME.unpack(prefix)
    if n_head + n_body > MAX_MESSAGE:
        raise ValueError(f"a message of {n_head + n_body} bytes (at most {MAX_MESSAGE})")
    head, body = _read_exactly(stream, n_head), _read_exactly(stream, n_body)
    if head is None or body is None:
        raise ValueError("a message cut short")
    header = json.loads(head)
    if not isinstance(header, dict) or not isinstance(header.get("arrays"), list):
        raise ValueError("a message without a header")
    arrays, offset = {}, 0
    for entry in header.pop("arrays"):
        name, shape = entry if isinstance(entry, list) and len(entry) == 2 else (None, None)
        if not isinstance(name, str) or not isinstance(shape, list) or not all(_is_count(n) for n in shape):
            raise ValueError("an array without a name or shape")
        size = math.prod(shape) * 8
        if offset + size > len(body):
            raise ValueError("arrays longer than the message")
        arrays[name] = np.frombuffer(body, dtype="<f8", count=size // 8, offset=offset).reshape(shape).copy()
        offset += size
    return header, arrays


def _is_count(n: object) -> bool:
    return isinstance(n, int) and not isinstance(n, bool) and n >= 0


def _read_exactly(stream: IO[bytes], n: int) -> bytes | None:
    chunks, got = [], 0
    while got < n:
        chunk = stream.read(n - got)
        if not chunk:
            return None
        chunks.append(chunk)
        got += len(chunk)
    return b"".join(chunks)
