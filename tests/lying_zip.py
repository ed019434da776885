"""A scene ``.zip`` whose directory under-states what its TOML inflates to (a "zip bomb"),
written without holding the inflated text in memory."""

from __future__ import annotations

import struct
import zlib
from pathlib import Path


def write_lying_zip(path: Path, inflated_bytes: int, declared_bytes: int = 1000) -> Path:
    """Write ``path``: one member ``scene.toml`` of ``inflated_bytes`` (a TOML line, then
    spaces) deflated, its local header and directory entry saying ``declared_bytes``."""
    text = b'name = "bomb"\n'
    chunk = b" " * 2**20
    compressor = zlib.compressobj(6, zlib.DEFLATED, -15)
    crc = zlib.crc32(text)
    data = [compressor.compress(text)]
    left = inflated_bytes - len(text)
    while left > 0:
        piece = chunk[: min(left, len(chunk))]
        crc = zlib.crc32(piece, crc)
        data.append(compressor.compress(piece))
        left -= len(piece)
    data.append(compressor.flush())
    compressed = b"".join(data)
    name = b"scene.toml"
    local = struct.pack("<4sHHHHHIIIHH", b"PK\x03\x04", 20, 0, 8, 0, 0, crc, len(compressed),
                        declared_bytes, len(name), 0) + name
    central = struct.pack("<4sHHHHHHIIIHHHHHII", b"PK\x01\x02", 20, 20, 0, 8, 0, 0, crc,
                          len(compressed), declared_bytes, len(name), 0, 0, 0, 0, 0, 0) + name
    offset = len(local) + len(compressed)
    end = struct.pack("<4sHHHHIIH", b"PK\x05\x06", 0, 0, 1, 1, len(central), offset, 0)
    path.write_bytes(local + compressed + central + end)
    return path


def many_member_zip(members: int) -> bytes:
    """A zip of ``members`` empty stored members (``m0``, ``m1``, ...): about 80 bytes a member,
    most of them in the central directory that ``zipfile`` reads whole as it opens."""
    local_parts, central_parts, offset = [], [], 0
    for index in range(members):
        name = b"m%d" % index
        local = struct.pack("<4sHHHHHIIIHH", b"PK\x03\x04", 20, 0, 0, 0, 0, 0, 0, 0,
                            len(name), 0) + name
        central_parts.append(struct.pack("<4sHHHHHHIIIHHHHHII", b"PK\x01\x02", 20, 20, 0, 0, 0,
                                         0, 0, 0, 0, len(name), 0, 0, 0, 0, 0, offset) + name)
        local_parts.append(local)
        offset += len(local)
    central = b"".join(central_parts)
    count = min(members, 0xFFFF)
    zip64 = b""
    if count == 0xFFFF:  # the ZIP64 end record and its locator, as zipfile writes them
        record_at = offset + len(central)
        zip64 = struct.pack("<4sQ2H2L4Q", b"PK\x06\x06", 44, 45, 45, 0, 0, members, members,
                            len(central), offset)
        zip64 += struct.pack("<4sLQL", b"PK\x06\x07", 0, record_at, 1)
    end = struct.pack("<4sHHHHIIH", b"PK\x05\x06", 0, 0, count, count, len(central), offset, 0)
    return b"".join(local_parts) + central + zip64 + end
