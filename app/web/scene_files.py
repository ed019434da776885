"""Scene files the web page may open: one directory chosen when the server starts, by name only.

The page never sends a path.  It shows the names this module lists and sends one of them back;
``SceneDirectory.load`` opens it only if it is (still) in the listing: a regular ``.toml`` file
directly in the directory, which, after following symlinks, is still inside the directory.
Anything else (``../x``, an absolute path, a device, a pipe, a symlink out of the directory, a
name that was never listed) is refused with ``SceneFileRefused``.  Saving goes to the user's
browser as a download and opening a file of one's own is an upload; neither touches the server's
disk (``sim.scenes.scene_files.to_bytes`` / ``from_bytes``).
"""

from __future__ import annotations

import stat
from pathlib import Path

import sim

MAX_LISTED = 500
MAX_PAGE_PARTICLES = 1_000_000
"""Largest lattice (nx * ny) the page builds or opens (a preset, a listed file or an upload);
bigger ones: the command line."""
"""At most this many scene files are offered (sorted by name)."""


class SceneFileRefused(ValueError):
    """The page asked for a scene file it may not open (the message says why)."""


class SceneDirectory:
    """The scene files in ``root`` (not created; a missing directory lists nothing)."""

    def __init__(self, root: str | Path) -> None:
        self.root = Path(root)

    def _resolved_root(self) -> Path | None:
        try:
            return self.root.resolve(strict=True)
        except OSError:
            return None

    def names(self) -> list[str]:
        """Names (``catenary-sag.toml``) of the regular ``.toml`` files inside the directory."""
        root = self._resolved_root()
        if root is None or not root.is_dir():
            return []
        found = []
        try:
            entries = sorted(root.iterdir())
        except OSError:
            return []
        for entry in entries:
            if entry.suffix != ".toml" or entry.name.startswith("."):
                continue
            if self._inside(entry, root):
                found.append(entry.name)
            if len(found) >= MAX_LISTED:
                break
        return found

    @staticmethod
    def _inside(entry: Path, root: Path) -> bool:
        try:
            target = entry.resolve(strict=True)
            mode = target.stat().st_mode
        except OSError:
            return False
        return target.parent == root and stat.S_ISREG(mode)

    def load(self, name: str) -> sim.Scene:
        """The scene in the listed file ``name``; ``SceneFileRefused`` if it is not listed, and
        ``sim.SceneError`` if the file is not a valid scene."""
        if not isinstance(name, str) or name not in self.names():
            raise SceneFileRefused(
                f"{name!r} is not one of the scene files offered by this server"
            )
        root = self._resolved_root()
        assert root is not None  # names() found it
        return sim.scenes.scene_files.load(root / name, within=root, max_particles=MAX_PAGE_PARTICLES)
