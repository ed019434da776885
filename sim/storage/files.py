"""Writing output files safely: where a file may go, and the one way every writer creates it.

Every file the program writes (recordings, movies, scene files, study pictures) goes through
``AtomicFile``:

* the target's folder must exist (a missing folder is an error, never created on the way);
* the content is written to ``NAME.partial`` beside the target, created exclusively
  (``O_CREAT | O_EXCL | O_NOFOLLOW``): a name that already exists, a symbolic link planted there
  included, is never opened, so nothing is written through a link;
* while it is written the ``.partial`` file holds an exclusive ``flock``: a second writer to
  the same target is refused with one line saying another program is writing it, and a
  ``.partial`` left by an interrupted writer is named as such (and kept: it may be readable);
* ``commit()`` syncs the file and renames it over the target only when complete (without
  ``overwrite`` it is linked into place, so a target that appeared meanwhile is not replaced).

Default names come from ``default_output``: a scene's name is made a plain file name
(``safe_name``) inside the output folder, so a name such as ``/etc/cron.d/x`` or ``../../x``
cannot leave it.  Refusals raise ``OutputError`` (a ``ValueError``: the CLI prints one line and
exits 2).
"""

from __future__ import annotations

import os
import re
from pathlib import Path
from typing import IO, Any

try:
    import fcntl
except ImportError:  # pragma: no cover - not POSIX: no advisory locks, O_EXCL still refuses
    fcntl = None  # type: ignore[assignment]

PARTIAL_SUFFIX = ".partial"
_UNSAFE = re.compile(r"[^A-Za-z0-9._-]+")


class OutputError(ValueError):
    """An output file cannot be written there (the message says why, in one line)."""


def safe_name(text: str, fallback: str = "scene", limit: int = 60) -> str:
    """``text`` as a plain file name: letters, digits, ``.``, ``_`` and ``-`` only (any other
    run of characters, ``/`` included, becomes ``_``), no leading dot, at most ``limit``
    characters; ``fallback`` when nothing is left."""
    name = _UNSAFE.sub("_", str(text)).lstrip("._")[:limit].rstrip("._") or fallback
    return name if name not in (".", "..") else fallback


def default_output(folder: str | os.PathLike, name: str, suffix: str) -> Path:
    """``folder/<safe_name(name)><suffix>``: a default output path that stays inside
    ``folder`` whatever ``name`` holds."""
    folder = Path(folder)
    path = folder / (safe_name(name) + suffix)
    if path.parent != folder:  # safe_name leaves no separator; this holds it to that
        raise OutputError(f"{name!r} cannot name a file")
    return path


def partial_path(path: str | os.PathLike) -> Path:
    """The name a file has until it is complete: ``NAME.partial`` beside it."""
    path = Path(path)
    return path.with_name(path.name + PARTIAL_SUFFIX)


def check_target(path: str | os.PathLike, overwrite: bool, suffix: str | None = None) -> Path:
    """Refuse a target that cannot be written before any work is done: a wrong ending, a
    directory, an existing file without ``overwrite``, a folder that does not exist."""
    path = Path(path)
    if suffix is not None and path.suffix.lower() != suffix:
        raise OutputError(f"the output file must end in {suffix}, got {path}")
    if path.is_dir():
        raise OutputError(f"{path} is a directory; give a file name ending in "
                          f"{suffix or 'a suffix'}")
    if (path.exists() or path.is_symlink()) and not overwrite:
        raise OutputError(f"{path} already exists; use --force to replace it")
    folder = path.parent
    if not folder.is_dir():
        what = "is not a folder" if folder.exists() else "does not exist"
        raise OutputError(f"cannot write {path}: {folder} {what} (folders are not created on "
                          "the way; create it first)")
    return path


def _busy_reason(path: Path, partial: Path) -> str:
    """Why ``partial`` could not be created exclusively, in one line."""
    if partial.is_symlink():
        return (f"{partial} is a symbolic link; nothing is written through a link "
                "(remove it and try again)")
    try:
        descriptor = os.open(partial, os.O_RDONLY | getattr(os, "O_NOFOLLOW", 0))
    except OSError as error:
        return f"cannot write {path}: {partial} exists ({error.strerror})"
    try:
        if fcntl is not None:
            try:
                fcntl.flock(descriptor, fcntl.LOCK_SH | fcntl.LOCK_NB)
            except OSError:
                return (f"another program is writing {path} now ({partial} is open); wait "
                        "for it to finish or choose another output name")
    finally:
        os.close(descriptor)
    return (f"{partial} is left from an interrupted run (what it holds may still be "
            "readable); rename or remove it, or choose another output name")


class AtomicFile:
    """An exclusively created ``NAME.partial`` beside ``path``, renamed over ``path`` by
    ``commit()``.  Use it as a context manager (committed on success, removed on an error), or
    call ``commit()`` / ``discard()`` / ``keep_partial()`` yourself.

    ``file`` is an open binary file object on it; ``library_path`` is a name under which a
    library that insists on opening the file itself (rerun, PyAV) reaches this very file, never
    whatever a name in the folder points to later (``/proc/self/fd/N`` on Linux)."""

    def __init__(self, path: str | os.PathLike, overwrite: bool = False,
                 suffix: str | None = None) -> None:
        self.path = check_target(path, overwrite, suffix)
        self.partial = partial_path(self.path)
        self.overwrite = overwrite
        flags = (os.O_WRONLY | os.O_CREAT | os.O_EXCL | getattr(os, "O_NOFOLLOW", 0)
                 | getattr(os, "O_CLOEXEC", 0))
        try:
            self.descriptor = os.open(self.partial, flags, 0o644)
        except FileExistsError:
            raise OutputError(_busy_reason(self.path, self.partial)) from None
        except OSError as error:
            raise OutputError(f"cannot write {self.partial}: {error.strerror}") from None
        if fcntl is not None:
            # blocking: a writer refused at the same moment may hold a shared lock for as long
            # as ``_busy_reason`` takes to look (the name is ours alone, nobody else waits on it)
            fcntl.flock(self.descriptor, fcntl.LOCK_EX)
        self.file: IO[bytes] = os.fdopen(self.descriptor, "wb", closefd=False)
        self.done = False

    @property
    def library_path(self) -> str:
        proc = f"/proc/self/fd/{self.descriptor}"
        return proc if os.path.exists(proc) else str(self.partial)

    def _still_ours(self) -> bool:
        """True if the name ``partial`` still is the file this object created."""
        try:
            named = os.lstat(self.partial)
        except OSError:
            return False
        mine = os.fstat(self.descriptor)
        return (named.st_dev, named.st_ino) == (mine.st_dev, mine.st_ino)

    def commit(self) -> Path:
        """Sync the file and give it its final name (the target); returns the target."""
        if self.done:
            return self.path
        self.file.flush()
        os.fsync(self.descriptor)
        if not self._still_ours():
            self.discard()
            raise OutputError(f"{self.partial} was replaced while it was written; nothing "
                              f"was written to {self.path}")
        try:
            if self.overwrite:
                os.replace(self.partial, self.path)
            else:
                try:
                    os.link(self.partial, self.path)
                except FileExistsError:
                    raise OutputError(f"{self.path} appeared while it was written; what was "
                                      f"written stays in {self.partial}") from None
                os.unlink(self.partial)
        finally:
            self._close()
        return self.path

    def keep_partial(self) -> Path:
        """Stop writing and leave the file under its ``.partial`` name; returns that name."""
        self._close()
        return self.partial

    def discard(self) -> None:
        """Remove the ``.partial`` file (if it still is ours) and stop."""
        if self.done:
            return
        if self._still_ours():
            os.unlink(self.partial)
        self._close()

    def _close(self) -> None:
        if not self.done:
            self.done = True
            try:
                self.file.close()
            finally:
                os.close(self.descriptor)

    def __enter__(self) -> AtomicFile:
        return self

    def __exit__(self, kind: Any, value: Any, traceback: Any) -> None:
        if kind is None:
            self.commit()
        else:
            self.discard()


def write_bytes(path: str | os.PathLike, data: bytes, overwrite: bool = False) -> Path:
    """Write ``data`` to ``path`` through ``AtomicFile``; returns the path."""
    with AtomicFile(path, overwrite) as output:
        output.file.write(data)
    return output.path
