"""The zip archives of scene files, read defensively: a scene's ``.npz`` arrays and the
``.zip`` of a scene's TOML and arrays.

An archive is opened only once its end record says its directory is small
(``small_zip``, ``sim.storage.zip_directory``); a member is inflated a chunk at a time with a
running count (``read_member``); an ``.npz``'s members are checked against the lattice before
any array is read (``read_arrays``).
"""

from __future__ import annotations

import math
import os
import zipfile
from typing import Any

import numpy as np

from sim.scenes.building import SceneError
from sim.storage.zip_directory import ZipDirectoryError, check_directory

ARRAY_MEMBERS = ("masses", "displacements", "velocities")
"""The arrays an ``.npz`` scene file may hold; any other member is refused."""

NPY_HEADER_BYTES = 4096
"""Room allowed for the ``.npy`` header of each member (numpy writes 128 bytes)."""


def expected_shapes(nx: int, ny: int, dim: int) -> dict[str, tuple[tuple[int, ...], ...]]:
    n = nx * ny
    return {"masses": ((ny, nx), (n,)), "displacements": ((n, dim),), "velocities": ((n, dim),)}


def read_arrays(source: Any, nx: int, ny: int, dim: int, label: str) -> dict[str, np.ndarray]:
    """The arrays of an ``.npz`` scene file (a path or a binary file object) for an nx x ny
    lattice in ``dim`` dimensions.

    Before any array is read, every member is checked: its name is one of ``ARRAY_MEMBERS``
    (other members are refused), its ``.npy`` header gives a numeric dtype of at most 8 bytes and
    the shape the lattice needs (masses (ny, nx) or (n_particles,), displacements and velocities
    (n_particles, dim)), and its uncompressed size in the zip directory fits that shape.  So a
    small file that would unpack to gigabytes is refused without allocating.  Never unpickles.
    """
    shapes = expected_shapes(nx, ny, dim)
    largest = {key: max(math.prod(shape) for shape in options) * 8 + NPY_HEADER_BYTES
               for key, options in shapes.items()}
    try:
        with small_zip(source, len(ARRAY_MEMBERS), label) as archive:
            members = archive.infolist()
            checked: dict[str, zipfile.ZipInfo] = {}
            for info in members:
                key = info.filename.removesuffix(".npy")
                if key not in shapes or not info.filename.endswith(".npy") or key in checked:
                    raise SceneError(f"{label}: unexpected member {info.filename!r} (allowed: "
                                     f"{', '.join(name + '.npy' for name in ARRAY_MEMBERS)})")
                if info.file_size > largest[key]:
                    raise SceneError(f"{label}: {info.filename} unpacks to {info.file_size:,} "
                                     f"bytes, more than a {nx}x{ny} lattice needs")
                with archive.open(info) as member:
                    shape, dtype = _npy_header(member, f"{label}: {info.filename}")
                if shape not in shapes[key]:
                    wanted = " or ".join(str(option) for option in shapes[key])
                    raise SceneError(f"{label}: {key} has shape {shape}; a {nx}x{ny} lattice in "
                                     f"{dim}-D needs {wanted}")
                if dtype.kind not in "fiu" or dtype.itemsize > 8 or dtype.hasobject:
                    raise SceneError(f"{label}: {key} has dtype {dtype}; want float64 numbers")
                if info.file_size > math.prod(shape) * dtype.itemsize + NPY_HEADER_BYTES:
                    raise SceneError(f"{label}: {info.filename} is larger than its header says")
                checked[key] = info
            arrays = {}
            for key, info in checked.items():
                with archive.open(info) as member:
                    arrays[key] = np.lib.format.read_array(member, allow_pickle=False)
            return arrays
    except SceneError:
        raise
    except (OSError, ValueError, EOFError, zipfile.BadZipFile, zipfile.LargeZipFile) as error:
        raise SceneError(f"cannot read the array file {label}: {error}") from None


def _npy_header(member: Any, label: str) -> tuple[tuple[int, ...], np.dtype]:
    version = np.lib.format.read_magic(member)
    if version == (1, 0):
        shape, _, dtype = np.lib.format.read_array_header_1_0(member)
    elif version == (2, 0):
        shape, _, dtype = np.lib.format.read_array_header_2_0(member)
    else:
        raise SceneError(f"{label}: unsupported .npy version {version}")
    return tuple(int(size) for size in shape), np.dtype(dtype)


_INFLATE_CHUNK = 2**16


def small_zip(source: Any, members: int, label: str, open_it: bool = True) -> Any:
    """``source`` (a path or a seekable binary file) opened as a ``ZipFile`` once its end
    record says it lists at most ``members`` members in a small directory: ``ZipFile`` reads the
    whole directory as it opens, whatever its size (``zip_directory``)."""
    try:
        if isinstance(source, (str, os.PathLike)):
            with open(source, "rb") as stream:
                check_directory(stream, members, label)
        else:
            check_directory(source, members, label)
    except ZipDirectoryError as error:
        raise SceneError(str(error)) from None
    return zipfile.ZipFile(source) if open_it else None


def read_member(archive: zipfile.ZipFile, info: zipfile.ZipInfo, limit: int, label: str) -> bytes:
    """A zip member inflated a chunk at a time with a running count, refused the moment it
    passes ``limit`` bytes: neither the directory's stated size nor a single large inflate is
    trusted (``ZipFile.read`` inflates a member in one call, as large as the data makes it)."""
    chunks, total = [], 0
    with archive.open(info) as member:
        while chunk := member.read(_INFLATE_CHUNK):
            total += len(chunk)
            if total > limit:
                raise SceneError(f"{label}: {info.filename} unpacks to more than the "
                                 f"{limit:,} bytes allowed")
            chunks.append(chunk)
    return b"".join(chunks)
