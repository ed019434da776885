"""The file a recording is written to: its name, the ``.partial`` name it has while being
written, and the checks of the path and the free disk space (before the first step and during
the run)."""

from __future__ import annotations

import shutil
from pathlib import Path

MIN_FREE_BYTES = 16 * 2**20
"""Free bytes a recording needs besides its own estimated size; during the run it stops when
less than a quarter of this is left."""


class RecordingError(RuntimeError):
    """The recording cannot be made or went wrong (the message says why and what to do)."""


def partial_path(path: Path) -> Path:
    """The name a recording has until it is complete: ``NAME.rrd.partial``."""
    return path.with_name(path.name + ".partial")


def check_destination(path: Path, overwrite: bool, needed_bytes: float = 0.0) -> None:
    """Refuse a bad ``path`` (not ``.rrd``, a directory, an existing file without
    ``overwrite``), create its folder and an empty ``.partial`` file, and refuse when less than
    ``needed_bytes`` + ``MIN_FREE_BYTES`` are free there (the ``.partial`` file is removed)."""
    directory = path.parent
    partial = partial_path(path)
    if path.suffix != ".rrd":
        raise RecordingError(f"the recording file must end in .rrd, got {path}")
    if path.is_dir():
        raise RecordingError(f"{path} is a directory; give a file name ending in .rrd")
    if path.exists() and not overwrite:
        raise RecordingError(f"{path} already exists; use --force to replace it")
    try:
        directory.mkdir(parents=True, exist_ok=True)
        with open(partial, "wb"):
            pass
    except OSError as error:
        raise RecordingError(f"cannot write {partial}: {error.strerror}") from None
    needed = MIN_FREE_BYTES + int(needed_bytes)
    free = shutil.disk_usage(directory).free
    if free < needed:
        partial.unlink(missing_ok=True)
        raise RecordingError(
            f"not enough disk space in {directory}: the recording needs about "
            f"{needed / 1e6:.0f} MB, {free / 1e6:.0f} MB free "
            "(record fewer frames, use --every, or --field video)"
        )


def check_space(directory: Path) -> None:
    """Stop a recording in progress when the disk is nearly full."""
    free = shutil.disk_usage(directory).free
    if free < MIN_FREE_BYTES // 4:
        raise RecordingError(f"disk nearly full in {directory} ({free / 1e6:.1f} MB free)")
