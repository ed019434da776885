"""A zip archive's directory, sized up before anyone reads it.

``zipfile.ZipFile`` reads an archive's whole central directory, and makes one ``ZipInfo`` per
member, before a caller can look at a single entry: a 60 MB archive of 800,000 empty members
costs it over 500 MB.  ``check_directory`` reads only the end-of-directory record (the last
bytes of the archive, in the ZIP64 form too) and refuses an archive whose member count or
directory size is over the caller's bounds, so ``ZipFile`` is opened only on archives whose
directory is small.
"""

from __future__ import annotations

import struct
from typing import BinaryIO

_END = b"PK\x05\x06"
_END_SIZE = 22
_END_FORMAT = "<4s4H2LH"
_ZIP64_LOCATOR = b"PK\x06\x07"
_ZIP64_LOCATOR_SIZE = 20
_ZIP64_END = b"PK\x06\x06"
_ZIP64_END_SIZE = 56
_ZIP64_END_FORMAT = "<4sQ2H2L4Q"
_MAX_COMMENT = 2**16 - 1

MAX_DIRECTORY_BYTES = 2**16
"""Largest central directory read by default (64 kB): a member's entry is 46 bytes and its
name; a scene's archives hold two or three members with short names."""


class ZipDirectoryError(ValueError):
    """An archive's directory is over its bounds, or its end record cannot be found."""


def directory_size(stream: BinaryIO, label: str = "the archive") -> tuple[int, int]:
    """(members, directory bytes) stated by the end record of the zip archive in ``stream`` (a
    seekable binary file), reading at most the archive's last 64 kB.  Raises
    ``ZipDirectoryError`` when there is no end record."""
    stream.seek(0, 2)
    length = stream.tell()
    tail_length = min(length, _END_SIZE + _MAX_COMMENT)
    stream.seek(length - tail_length)
    tail = stream.read(tail_length)
    at = tail.rfind(_END)
    if at < 0 or len(tail) - at < _END_SIZE:
        raise ZipDirectoryError(f"{label} is not a zip archive (it has no end record)")
    fields = struct.unpack(_END_FORMAT, tail[at:at + _END_SIZE])
    members, directory = fields[4], fields[5]
    if members == 0xFFFF or directory == 0xFFFFFFFF:
        return _zip64_size(stream, length - tail_length + at) or (members, directory)
    return members, directory


def _zip64_size(stream: BinaryIO, end_at: int) -> tuple[int, int] | None:
    """(members, directory bytes) of the ZIP64 end record, or None where there is no ZIP64
    locator before the end record (a plain archive whose count is 65,535, as ``zipfile``
    reads it too)."""
    locator_at = end_at - _ZIP64_LOCATOR_SIZE
    if locator_at < 0:
        return None
    stream.seek(locator_at)
    locator = stream.read(_ZIP64_LOCATOR_SIZE)
    if not locator.startswith(_ZIP64_LOCATOR):
        return None
    record_at = locator_at - _ZIP64_END_SIZE
    if record_at < 0:
        raise ZipDirectoryError("a ZIP64 archive whose end record is missing")
    stream.seek(record_at)
    record = stream.read(_ZIP64_END_SIZE)
    if len(record) < _ZIP64_END_SIZE or not record.startswith(_ZIP64_END):
        raise ZipDirectoryError("a ZIP64 archive whose end record is missing")
    fields = struct.unpack(_ZIP64_END_FORMAT, record)
    return fields[7], fields[8]


def check_directory(stream: BinaryIO, max_members: int, label: str,
                    max_directory_bytes: int = MAX_DIRECTORY_BYTES) -> None:
    """Refuse (``ZipDirectoryError``, saying what was found and what is allowed) the zip archive
    in ``stream`` if its directory lists more than ``max_members`` members or is larger than
    ``max_directory_bytes``; leave ``stream`` at its start."""
    members, directory = directory_size(stream, label)
    stream.seek(0)
    if members > max_members:
        raise ZipDirectoryError(f"{label} lists {members:,} members; at most {max_members} "
                                "are allowed")
    if directory > max_directory_bytes:
        raise ZipDirectoryError(f"{label} has a directory of {directory:,} bytes; at most "
                                f"{max_directory_bytes:,} are allowed")
