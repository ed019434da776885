"""The file a recording is written to: opening it safely (``sim.storage.files.AtomicFile``: an exclusive
``NAME.rrd.partial`` beside the target, renamed when complete), the free disk space it needs
(checked before the first step and during the run), and how much of a ``.partial`` file left by
a killed recorder can be read back.

An ``.rrd`` file is a 12-byte stream header followed by messages, each a 16-byte header (kind and
payload length, little-endian u64) and its payload; a complete file ends with an end message and
a 32-byte footer.  rerun's reader refuses a file whose last message is cut, but reads a file cut
at a message boundary, so ``readable_part`` finds the last whole message and ``salvage`` copies
the file up to it.
"""

from __future__ import annotations

import fcntl
import os
import shutil
import struct
import threading
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from time import monotonic
from typing import Any

from app.recording.rerun_lazy import rr
from sim.storage.files import AtomicFile, OutputError, partial_path

__all__ = ["AtomicFile", "RecordingError", "partial_path"]

RESERVE_BYTES = 1 * 2**20
"""Free bytes a recording keeps in hand besides its own estimated size: room for the last
messages, the ERROR entry and the footer.  During the run it stops when less than this (or
three times what one flush interval writes, if more) is left."""

STATIC_BYTES = 250e3
"""What a recording holds besides its frames: the read-me, colour bars, blueprint (measured:
about 250 kB)."""

_HEADER = struct.Struct("<QQ")
_STREAM_HEADER_BYTES = 12
_MAGIC = b"RRF2"


class RecordingError(RuntimeError):
    """The recording cannot be made or went wrong (the message says why and what to do)."""


def free_bytes(directory: Path) -> int:
    """Free bytes on the file system of ``directory``."""
    return shutil.disk_usage(directory).free


def explain_failure(error: BaseException, directory: Path) -> BaseException:
    """``error`` (a write that failed) said in the user's words when the disk is what failed
    (less than ``RESERVE_BYTES`` free): rerun's writer only says it shut down."""
    if isinstance(error, RecordingError):  # already said in the user's words
        return error
    try:
        free = free_bytes(directory)
    except OSError:
        return error
    if free >= RESERVE_BYTES:
        return error
    explained = RecordingError(f"the disk holding {directory} is full ({free / 1e3:.0f} kB free; "
                               f"the writer said: {error})")
    explained.__cause__ = error
    return explained


def open_destination(path: Path, overwrite: bool, needed_bytes: float = 0.0) -> AtomicFile:
    """Refuse a bad ``path`` (not ``.rrd``, a directory, an existing file without
    ``overwrite``, a missing folder, a ``.partial`` that exists or is a link), create the
    ``.partial`` file exclusively, and refuse when less than ``needed_bytes`` + ``RESERVE_BYTES``
    are free there (the ``.partial`` file is removed)."""
    try:
        output = AtomicFile(path, overwrite, suffix=".rrd")
    except OutputError as error:
        hint = (f"; `oscillators record {partial_path(path)}` keeps its readable part"
                if "interrupted run" in str(error) else "")
        raise RecordingError(f"{error}{hint}") from None
    needed = RESERVE_BYTES + int(needed_bytes)
    free = free_bytes(path.parent)
    if free < needed:
        output.discard()
        raise RecordingError(
            f"not enough disk space in {path.parent}: the recording needs about "
            f"{needed / 1e6:.2g} MB, {free / 1e6:.2g} MB free "
            "(record fewer frames, use --every, or --field video)"
        )
    return output


def check_space(directory: Path, bytes_per_interval: float = 0.0) -> None:
    """Stop a recording in progress while there is still room to end it readably: when less
    than ``RESERVE_BYTES`` or three flush intervals' worth of bytes are free."""
    free = free_bytes(directory)
    if free < max(RESERVE_BYTES, 3 * bytes_per_interval):
        raise RecordingError(f"disk nearly full in {directory} ({free / 1e6:.1f} MB free)")


FLUSH_SECONDS = 120.0
"""How long a flush may take before the recording fails (a slow or network disk)."""


def flush(stream: Any, directory: Path, bytes_per_interval: float = 0.0,
          timeout: float = FLUSH_SECONDS) -> None:
    """rerun's ``flush`` of ``stream`` into a file in ``directory``, waited for a second at a
    time with the disk's room checked in between (``check_space``): once rerun's file sink has
    failed to write (a disk another program filled), its flush waits out its whole timeout, and
    the recording would seem to hang for it instead of stopping with the reason."""
    deadline = monotonic() + timeout
    while True:
        try:
            stream.flush(timeout_sec=1.0)
            return
        except Exception as error:  # noqa: BLE001 - rerun raises on its timeout
            check_space(directory, bytes_per_interval)
            if monotonic() > deadline:
                raise RecordingError(f"rerun did not finish writing in {timeout:g} s "
                                     f"({error})") from error


DISCONNECT_SECONDS = 30.0
"""How long rerun may take to close a recording's file."""


def disconnect(stream: Any, timeout: float = DISCONNECT_SECONDS) -> bool:
    """rerun's ``disconnect`` of ``stream``, given ``timeout`` seconds: once its file sink has
    failed to write (a full disk), it may wait for ever.  Returns whether it ended; if not,
    rerun's writer is left behind and the file is ended by ``end_readably``, and a command
    should then end its process without rerun's exit handlers, which would wait for that
    writer too (``os._exit``)."""
    done = threading.Event()

    def close() -> None:
        try:
            stream.disconnect()
        finally:
            done.set()

    threading.Thread(target=close, name="rerun-disconnect", daemon=True).start()
    return done.wait(timeout)


@dataclass(frozen=True)
class ReadablePart:
    """How much of an ``.rrd`` file rerun can read: ``readable_bytes`` of ``total_bytes``, in
    ``messages`` whole messages; ``complete`` when it ends with its end message."""

    readable_bytes: int
    total_bytes: int
    messages: int
    complete: bool

    def describe(self, path: Path) -> str:
        if self.complete:
            return f"{path}: complete ({self.total_bytes / 1e6:.3g} MB)"
        if self.messages == 0:
            return f"{path}: nothing readable ({self.total_bytes} bytes)"
        return (f"{path}: {self.readable_bytes / 1e6:.3g} MB of {self.total_bytes / 1e6:.3g} MB "
                f"readable ({self.messages} whole messages; the rest was cut off)")


def _whole_messages(stream: Any, total: int) -> Iterator[tuple[int, int]]:
    """(kind, end position) of each whole message of an open ``.rrd`` ``stream`` of ``total``
    bytes, from its first stream header on (headers only read; streams appended to the file
    are stepped over); stops at a cut message and after the end message (kind 0)."""
    position = _STREAM_HEADER_BYTES
    while position + _HEADER.size <= total:
        stream.seek(position)
        header = stream.read(_HEADER.size)
        if header[:4] == _MAGIC:  # a further stream appended to the file
            position += _STREAM_HEADER_BYTES
            continue
        kind, length = _HEADER.unpack(header)
        end = position + _HEADER.size + length
        if end > total:
            return
        yield kind, end
        if kind == 0:
            return
        position = end


def readable_part(path: str | os.PathLike) -> ReadablePart:
    """Scan ``path`` message by message (headers only) and say how much is whole."""
    with open(path, "rb") as stream:
        total = os.fstat(stream.fileno()).st_size
        if stream.read(4) != _MAGIC:
            raise RecordingError(f"{path} is not a rerun recording")
        readable = _STREAM_HEADER_BYTES if total >= _STREAM_HEADER_BYTES else 0
        messages, complete = 0, False
        for kind, end in _whole_messages(stream, total):
            readable, messages, complete = end, messages + 1, kind == 0
    return ReadablePart(readable, total, messages, complete)


def salvage(partial: str | os.PathLike, output: str | os.PathLike, overwrite: bool = False
            ) -> ReadablePart:
    """Copy the readable part of ``partial`` (a recording cut off by a kill or a crash) to
    ``output`` (written atomically), or, when ``partial`` is ``output``'s own ``.partial``, cut
    it there and give it its final name; returns what was readable."""
    part = readable_part(partial)
    if part.messages == 0:
        raise RecordingError(part.describe(Path(partial)))
    if partial_path(output) == Path(partial):
        _salvage_in_place(Path(partial), Path(output), part, overwrite)
        return part
    try:
        with AtomicFile(output, overwrite, suffix=".rrd") as target, open(partial, "rb") as source:
            remaining = part.readable_bytes
            while remaining > 0:
                block = source.read(min(remaining, 2**20))
                if not block:
                    break
                target.file.write(block)
                remaining -= len(block)
    except OutputError as error:
        raise RecordingError(str(error)) from None
    return part


def _salvage_in_place(partial: Path, output: Path, part: ReadablePart, overwrite: bool) -> None:
    if (output.exists() or output.is_symlink()) and not overwrite:
        raise RecordingError(f"{output} already exists; use --force to replace it")
    descriptor = os.open(partial, os.O_RDWR | getattr(os, "O_NOFOLLOW", 0))
    try:
        try:
            fcntl.flock(descriptor, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            raise RecordingError(f"another program is writing {partial} now") from None
        os.truncate(descriptor, part.readable_bytes)
        os.fsync(descriptor)
        if overwrite:
            os.replace(partial, output)
        else:
            os.link(partial, output)
            os.unlink(partial)
    finally:
        os.close(descriptor)


def _messages(data: bytes) -> bytes:
    """The messages of one encoded stream, without its stream header, end message and footer."""
    position, kept = _STREAM_HEADER_BYTES, []
    while position + _HEADER.size <= len(data):
        kind, length = _HEADER.unpack_from(data, position)
        if kind == 0:
            break
        kept.append(data[position: position + _HEADER.size + length])
        position += _HEADER.size + length
    return b"".join(kept)


def end_readably(output: AtomicFile, application_id: str, recording_id: str, text: str,
                 entries: Sequence[tuple[str, int | None, float | None]]) -> None:
    """Make a recording whose writer failed readable: cut it after its last whole message and,
    if it has no end message, append ``text`` as an ERROR entry at each of ``entries``
    (entity, step, sim_time), encoded by rerun as messages of the same recording.  When the
    entry does not fit (a full disk, a short write), the last frames are given up to make room
    for it (``ROOM_SLACK``); if even that fails the file is cut back to its last whole message:
    it always ends readably."""
    part = readable_part(output.library_path)
    if part.complete:
        return
    os.truncate(output.descriptor, part.readable_bytes)
    stream = rr.RecordingStream(application_id, recording_id=recording_id,
                                send_properties=False)
    encoded = stream.binary_stream()
    for entity, step, time in entries:
        if step is not None:
            stream.set_time("step", sequence=step)
            stream.set_time("sim_time", duration=time or 0.0)
        stream.log(entity, rr.TextLog(text, level="ERROR"))
    data = encoded.read(flush=True) or b""
    stream.disconnect()
    payload = _messages(data)
    end = part.readable_bytes
    if not _write_at(output.descriptor, payload, end):
        # a full disk: give up the last frames, as many bytes as the entry and some slack (the
        # file system's blocks), and write it there instead
        ends = message_ends(output.library_path)
        room = [position for position in ends if position <= end - len(payload) - ROOM_SLACK]
        if room and room[-1] > _STREAM_HEADER_BYTES:
            end = room[-1]
            os.truncate(output.descriptor, end)
            _write_at(output.descriptor, payload, end)


ROOM_SLACK = 64 * 1024
"""Bytes given up besides the ERROR entry's own when it must make room for itself on a full disk
(a file system frees and allocates whole blocks)."""


def _write_at(descriptor: int, payload: bytes, position: int) -> bool:
    """Write ``payload`` at ``position`` as the file's end; on a short write or an error (a full
    disk) cut the file back to ``position`` (its last whole message) and say False."""
    try:
        written = os.pwrite(descriptor, payload, position)
    except OSError:
        written = -1
    if written != len(payload):  # never leave a cut message: end at the last whole one
        os.truncate(descriptor, position)
        return False
    return True


def message_ends(path: str | os.PathLike) -> list[int]:
    """The byte positions at which each whole message of ``path`` ends (headers only read)."""
    with open(path, "rb") as stream:
        return [end for _, end in _whole_messages(stream, os.fstat(stream.fileno()).st_size)]
