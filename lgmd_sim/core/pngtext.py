"""What made a figure, written into it: the command and its configuration as PNG text
chunks, so that a figure in the docs can be checked against what today's command makes.

Matplotlib writes them with ``fig.savefig(..., metadata=png_text(...))``; an image encoded
otherwise (OpenCV) gets them with `add_text`. `read_text` reads them back (tEXt, zTXt and
iTXt chunks), with the standard library only.
"""

from __future__ import annotations

import json
import os
import struct
import zlib
from collections.abc import Mapping
from pathlib import Path
from typing import Any

__all__ = ["COMMAND", "CONFIG", "add_text", "png_text", "read_config", "read_text"]

#: The keys: the command line that made the figure, and its configuration (JSON).
COMMAND, CONFIG = "lgmd-sim:command", "lgmd-sim:config"
_SIGNATURE = b"\x89PNG\r\n\x1a\n"


def png_text(command: str | None = None, config: Mapping[str, Any] | None = None
             ) -> dict[str, str]:
    """The text chunks of a figure made by `command` with `config` (JSON-ready): what
    ``savefig(metadata=...)`` and `add_text` take; a part that is None is left out."""
    text = {}
    if command is not None:
        text[COMMAND] = command
    if config is not None:
        text[CONFIG] = json.dumps(config, sort_keys=True, allow_nan=False)
    return text


def _chunk(kind: bytes, data: bytes) -> bytes:
    return (struct.pack(">I", len(data)) + kind + data
            + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF))


def add_text(png: bytes, text: Mapping[str, str]) -> bytes:
    """`png` (an encoded PNG) with `text`'s chunks added after its header: tEXt where the
    value is Latin-1, else iTXt (UTF-8)."""
    if png[:8] != _SIGNATURE:
        raise ValueError("not a PNG")
    (length,) = struct.unpack(">I", png[8:12])
    end = 8 + 12 + length  # the IHDR chunk, which comes first
    chunks = []
    for key, value in text.items():
        try:
            chunks.append(_chunk(b"tEXt", key.encode("latin-1") + b"\0"
                                 + value.encode("latin-1")))
        except UnicodeEncodeError:
            chunks.append(_chunk(b"iTXt", key.encode("latin-1") + b"\0\0\0\0\0"
                                 + value.encode("utf-8")))
    return png[:end] + b"".join(chunks) + png[end:]


def read_text(png: bytes | str | os.PathLike) -> dict[str, str]:
    """The text chunks of a PNG (its bytes or its path), key -> value."""
    data = png if isinstance(png, bytes) else Path(png).read_bytes()
    if data[:8] != _SIGNATURE:
        raise ValueError("not a PNG")
    out: dict[str, str] = {}
    at = 8
    while at + 8 <= len(data):
        length, kind = struct.unpack(">I4s", data[at:at + 8])
        body = data[at + 8:at + 8 + length]
        at += 12 + length
        if kind == b"IEND":
            break
        if kind not in (b"tEXt", b"zTXt", b"iTXt"):
            continue
        key, _, rest = body.partition(b"\0")
        if kind == b"tEXt":
            value = rest.decode("latin-1")
        elif kind == b"zTXt":
            value = zlib.decompress(rest[1:]).decode("latin-1")
        else:
            compressed, rest = rest[0], rest[2:]
            _, _, rest = rest.partition(b"\0")  # language
            _, _, rest = rest.partition(b"\0")  # translated keyword
            value = (zlib.decompress(rest) if compressed else rest).decode("utf-8")
        out[key.decode("latin-1")] = value
    return out


def read_config(png: bytes | str | os.PathLike) -> tuple[str | None, dict[str, Any] | None]:
    """The command and the configuration a PNG was made with (None where it has none)."""
    text = read_text(png)
    config = text.get(CONFIG)
    return text.get(COMMAND), None if config is None else json.loads(config)
