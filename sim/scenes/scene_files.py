"""Scene files: a scene written as a human-editable TOML file and read back, defensively.

``save`` / ``load`` write and read a scene as a TOML file (arrays that are not uniform go in a
``.npz`` file beside it, named in the TOML); ``to_bytes`` / ``from_bytes`` do the same with the
content of one file (a ``.toml``, or a ``.zip`` of the TOML and its ``.npz``), for downloads and
uploads.  The TOML is parsed with ``tomllib`` and written with ``tomli_w``.

Reading is defensive, as scene files may come from anyone: only regular files of bounded size
(``MAX_SCENE_FILE_BYTES``, ``MAX_UPLOAD_BYTES``), an array file only beside the TOML, optionally
only inside a given directory (``load(path, within=...)``), and every ``.npz`` member's shape,
dtype and unpacked size checked against the lattice before it is read (``read_arrays``).
"""

from __future__ import annotations

import io
import math
import os
import stat
import tomllib
import zipfile
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import tomli_w

from sim.forces import registry
from sim.model import schema
from sim.model.lattice import Model, ModelError, _whole_number, check_size
from sim.scenes.building import OVERRIDES, Scene, SceneError
from sim.scenes.scene_archives import (
    NPY_HEADER_BYTES,
    expected_shapes,
    read_arrays,
    read_member,
    small_zip,
)
from sim.storage.files import AtomicFile, write_bytes

FORMAT_VERSION = 1

MAX_SCENE_FILE_BYTES = 2**20
"""Largest scene TOML file read (1 MB): a hand-written scene is a few kB, and ``save`` writes at
most 64 sparse displacement rows before it moves them to the ``.npz``."""

MAX_UPLOAD_BYTES = 64 * 2**20
"""Largest scene given to ``from_bytes`` (64 MB): the masses, displacements and velocities of the
682x383 interference lattice take 10.4 MB uncompressed."""

_ZIP_MAGIC = b"PK\x03\x04"

_HEADER = """\
# coupled-oscillators scene file: edit freely; units are SI (m, kg, s, N/m, N s/m).
# [model.driver], if any, is a sinusoidal driver: kind force (A k sin 2 pi f t, N) or
# displacement (A sin 2 pi f t, m); [[model.sources]] are more of them (row = "all" drives a column,
# phase in rad) and [[model.barriers]] pin a column (or row) except its openings [[first, last]].
# [initial] displacements are rows [particle index, dx, dy(, dz)]
# of displacements from rest (m).

"""


def _scene_document(scene: Scene, array_file_name: str) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    """The TOML document (plain Python values) of ``scene`` and the arrays that go to
    ``array_file_name`` (may be empty, then the document names no array file)."""
    model = scene.model
    arrays: dict[str, np.ndarray] = {}
    mass: Any = float(model.masses.flat[0])
    if not model.uniform_mass:
        arrays["masses"] = np.asarray(model.masses)
        mass = "arrays:masses"
    displacement = scene.initial_positions - model.rest_positions
    if np.any(displacement != 0):
        arrays["displacements"] = displacement
    if np.any(scene.initial_velocities != 0):
        arrays["velocities"] = np.asarray(scene.initial_velocities)
    model_table: dict[str, Any] = {
        "nx": model.nx, "ny": model.ny, "dim": model.dim, "spacing": float(model.spacing),
        "mass": mass, "linear": bool(model.linear), "boundary": model.boundary,
    }
    for row in registry.parameters():  # every force term's, set or not, to be edited
        model_table[row.name] = _plain(getattr(model, row.name))
    if model.walls.absorbing:
        model_table.update(sponge_width=int(model.sponge_width),
                           sponge_strength=float(model.sponge_strength),
                           sponge_sides=list(model.sponge_sides))
    if model.driver is not None:
        model_table["driver"] = model.driver.as_table()
    if model.sources:
        model_table["sources"] = [source.as_table() for source in model.sources]
    if model.barriers:
        model_table["barriers"] = [barrier.as_table() for barrier in model.barriers]
    document: dict[str, Any] = {
        "format": FORMAT_VERSION, "name": str(scene.name), "description": str(scene.description),
        "integrator": str(scene.integrator), "dt": float(scene.dt),
        "duration": float(scene.duration), "precision": str(scene.precision), "model": model_table,
    }
    sparse = _sparse_displacements(displacement) if "displacements" in arrays else None
    if sparse is not None:
        del arrays["displacements"]
        document["initial"] = {"displacements": sparse}
    if arrays:
        document["arrays"] = {"file": array_file_name}
    return document, arrays


def _plain(value: Any) -> Any:
    """A parameter's value as TOML writes it: floats, booleans and lists of floats."""
    if isinstance(value, bool):
        return value
    if isinstance(value, tuple | list):
        return [float(component) for component in value]
    return float(value)


def _scene_text(scene: Scene, array_file_name: str) -> tuple[str, dict[str, np.ndarray]]:
    """The TOML text of ``scene`` and the arrays that go to ``array_file_name``."""
    document, arrays = _scene_document(scene, array_file_name)
    return _HEADER + tomli_w.dumps(document), arrays




def save(scene: Scene, path: str | Path, overwrite: bool = True) -> Path:
    """Write ``scene`` to ``path`` (.toml).  Non-uniform masses and any displacement or velocity
    that is not sparse go to ``<path stem>.npz`` beside it (named in the TOML).  Both are written
    through ``sim.storage.files.AtomicFile`` (the folder must exist).  Returns the TOML path."""
    path = Path(path)
    if path.suffix != ".toml":
        path = path.with_suffix(".toml")
    array_path = path.with_suffix(".npz")
    text, arrays = _scene_text(scene, array_path.name)
    if arrays:
        with AtomicFile(array_path, overwrite) as output:
            np.savez_compressed(output.file, **arrays)
    write_bytes(path, text.encode("utf-8"), overwrite)
    return path


def to_bytes(scene: Scene) -> tuple[str, bytes]:
    """``scene`` as the content of one file, for a download: ``(".toml", TOML text)`` when it
    needs no arrays, else ``(".zip", zip of scene.toml and scene.npz)`` (what ``save`` writes).
    ``from_bytes`` reads either back."""
    text, arrays = _scene_text(scene, "scene.npz")
    if not arrays:
        return ".toml", text.encode("utf-8")
    arrays_buffer = io.BytesIO()
    np.savez_compressed(arrays_buffer, **arrays)
    package = io.BytesIO()
    with zipfile.ZipFile(package, "w") as archive:
        archive.writestr("scene.toml", text, compress_type=zipfile.ZIP_DEFLATED)
        archive.writestr("scene.npz", arrays_buffer.getvalue(), compress_type=zipfile.ZIP_STORED)
    return ".zip", package.getvalue()


def _sparse_displacements(displacement: np.ndarray, limit: int = 64) -> list | None:
    moved = np.flatnonzero(np.any(displacement != 0, axis=1))
    if moved.size > limit:
        return None
    return [[int(p)] + [float(v) for v in displacement[p]] for p in moved]


# --- reading: checked before anything large is read or allocated ------------------------------------


def _inside(path: Path, root: Path | None, what: str) -> None:
    """With a root directory, ``path`` must resolve (symlinks followed) inside it."""
    if root is not None and not path.resolve().is_relative_to(root):
        raise SceneError(f"the {what} {path} is outside {root}")


def _read_regular_file(path: Path, limit: int, what: str, zip_members: int = 0) -> bytes:
    """The content of ``path`` if it is a regular file of at most ``limit`` bytes.  A directory,
    a device or a named pipe is refused before it is opened (and the opened file is checked
    again, without blocking, in case it was swapped meanwhile).  ``zip_members``: the file is a
    zip archive of at most that many members, checked before it is read (``small_zip``)."""
    try:
        status = os.stat(path)
    except OSError as error:
        raise SceneError(f"cannot read {what} {path}: {error.strerror or error}") from None
    if not stat.S_ISREG(status.st_mode):
        raise SceneError(f"{path} is not a regular file; a {what} must be one")
    if status.st_size > limit:
        raise SceneError(
            f"{what} {path} is {status.st_size:,} bytes, more than the {limit:,} bytes allowed"
        )
    try:
        descriptor = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0))
    except OSError as error:
        raise SceneError(f"cannot read {what} {path}: {error.strerror or error}") from None
    with os.fdopen(descriptor, "rb") as stream:
        if not stat.S_ISREG(os.fstat(stream.fileno()).st_mode):
            raise SceneError(f"{path} is not a regular file; a {what} must be one")
        if zip_members:
            small_zip(stream, zip_members, f"{what} {path}", open_it=False)
        content = stream.read(limit + 1)
    if len(content) > limit:
        raise SceneError(f"{what} {path} is more than the {limit:,} bytes allowed")
    return content


def _array_file_name(document: dict[str, Any], label: str) -> str:
    """The ``[arrays] file`` entry: a bare file name beside the TOML (no directory part)."""
    table = document["arrays"]
    name = table.get("file") if isinstance(table, dict) else None
    if (not isinstance(name, str) or not name or name in (".", "..") or "/" in name
            or "\\" in name or "\0" in name or Path(name).is_absolute()):
        raise SceneError(
            f"{label}: [arrays] file must be the bare name of a file beside the scene file "
            f"(no directory), got {name!r}"
        )
    return name


def _lattice_shape(model_table: dict[str, Any], label: str) -> tuple[int, int, int]:
    """nx, ny, dim of a [model] table, validated (sizes and memory) before any array is read."""
    try:
        nx = _whole_number("nx", model_table.get("nx", 1))
        ny = _whole_number("ny", model_table.get("ny", 1))
        dim = model_table.get("dim", 2)
        if dim not in (2, 3) or isinstance(dim, bool):
            raise ModelError(f"dim must be 2 or 3, got {dim!r}")
        check_size(nx, ny, int(dim))
    except ModelError as error:
        raise SceneError(f"{label}: {error}") from None
    return nx, ny, int(dim)


def load(path: str | Path, *, within: str | Path | None = None,
         max_particles: int | None = None) -> Scene:
    """Read a scene file written by ``save`` (or by hand).  Raises ``SceneError`` saying what is
    wrong (missing file, not a regular file, too large, bad TOML, missing or invalid parameter,
    bad array file).

    ``within``: a directory the scene file and its array file must resolve into (symlinks
    followed), for callers that take names from users.  The ``[arrays] file`` entry must be a
    bare file name beside the TOML in any case.  Sizes: the TOML at most
    ``MAX_SCENE_FILE_BYTES``; the ``.npz`` is checked member by member (``read_arrays``).
    ``max_particles``: a lattice larger than this is refused before anything is built.
    """
    path = Path(path)
    root = Path(within).resolve() if within is not None else None
    _inside(path, root, "scene file")
    content = _read_regular_file(path, MAX_SCENE_FILE_BYTES, "scene file")
    document = _parse_toml(content, str(path))

    def arrays_for(nx: int, ny: int, dim: int) -> dict[str, np.ndarray]:
        array_path = path.parent / _array_file_name(document, str(path))
        _inside(array_path, root, "array file")
        shapes = expected_shapes(nx, ny, dim)
        limit = sum(max(math.prod(shape) for shape in options) * 8 + 2 * NPY_HEADER_BYTES
                    for options in shapes.values()) + 2**16
        content = _read_regular_file(array_path, limit, "array file")
        return read_arrays(io.BytesIO(content), nx, ny, dim, str(array_path))

    return _scene_from_document(document, str(path), path.stem, arrays_for, max_particles)


def load_file(path: str | Path, *, max_particles: int | None = None) -> Scene:
    """A scene file of either kind: a ``.toml`` (``load``) or the ``.zip`` that ``to_bytes``
    makes (read as a regular file of at most ``MAX_UPLOAD_BYTES``, then ``from_bytes``)."""
    path = Path(path)
    if path.suffix.lower() == ".zip":
        return from_bytes(_read_regular_file(path, MAX_UPLOAD_BYTES, "scene archive", 2),
                          path.name, max_particles=max_particles)
    return load(path, max_particles=max_particles)


def from_bytes(data: bytes, filename: str, *, max_particles: int | None = None) -> Scene:
    """A scene from the content of an uploaded file: a TOML scene (UTF-8 text) or the ``.zip``
    that ``to_bytes`` makes (decided by the content, not by ``filename``, which only names the
    scene when the TOML has no name).

    The same checks as ``load``: at most ``MAX_UPLOAD_BYTES`` in all and ``MAX_SCENE_FILE_BYTES``
    of TOML; a zip holds exactly one ``.toml`` member and at most one ``.npz`` member, both bare
    names (no directories), their sizes checked in the zip directory and again while they are
    inflated (a running count, ``read_member``);
    the TOML's ``[arrays] file`` names the ``.npz`` member; the arrays are checked as by
    ``read_arrays``.  Nothing is written to disk.
    """
    label = Path(str(filename)).name or "uploaded scene"
    if len(data) > MAX_UPLOAD_BYTES:
        raise SceneError(f"{label} is {len(data):,} bytes, more than the "
                         f"{MAX_UPLOAD_BYTES:,} bytes allowed")
    if not data.startswith(_ZIP_MAGIC):
        document = _parse_toml(_limited(data, MAX_SCENE_FILE_BYTES, label), label)

        def no_arrays(nx: int, ny: int, dim: int) -> dict[str, np.ndarray]:
            raise SceneError(f"{label} names an array file; upload the .zip of the scene "
                             "(its TOML and .npz together)")

        return _scene_from_document(document, label, Path(label).stem, no_arrays, max_particles)
    try:
        with small_zip(io.BytesIO(data), 2, label) as archive:
            members = archive.infolist()
            names = [info.filename for info in members]
            tomls = [info for info in members if info.filename.endswith(".toml")]
            npzs = [info for info in members if info.filename.endswith(".npz")]
            bare = all(name and "/" not in name and "\\" not in name and name not in (".", "..")
                       for name in names)
            if len(tomls) != 1 or len(npzs) > 1 or len(members) != len(tomls) + len(npzs) \
                    or not bare:
                raise SceneError(f"{label} must hold one .toml and at most one .npz file, "
                                 f"without directories; it holds {names[:5]}")
            if tomls[0].file_size > MAX_SCENE_FILE_BYTES:
                raise SceneError(f"{label}: {tomls[0].filename} is larger than the "
                                 f"{MAX_SCENE_FILE_BYTES:,} bytes allowed")
            if npzs and npzs[0].file_size > MAX_UPLOAD_BYTES:
                raise SceneError(f"{label}: {npzs[0].filename} is larger than the "
                                 f"{MAX_UPLOAD_BYTES:,} bytes allowed")
            document = _parse_toml(read_member(archive, tomls[0], MAX_SCENE_FILE_BYTES, label),
                                   f"{label}: {tomls[0].filename}")
            npz = read_member(archive, npzs[0], MAX_UPLOAD_BYTES, label) if npzs else None
    except SceneError:
        raise
    except (OSError, ValueError, EOFError, zipfile.BadZipFile, zipfile.LargeZipFile) as error:
        raise SceneError(f"cannot read {label}: {error}") from None

    def arrays_in_zip(nx: int, ny: int, dim: int) -> dict[str, np.ndarray]:
        name = _array_file_name(document, label)
        if npz is None or name != npzs[0].filename:
            raise SceneError(f"{label}: the array file {name!r} is not in the zip")
        return read_arrays(io.BytesIO(npz), nx, ny, dim, f"{label}: {name}")

    return _scene_from_document(document, label, Path(tomls[0].filename).stem, arrays_in_zip,
                                max_particles)


def _limited(data: bytes, limit: int, label: str) -> bytes:
    if len(data) > limit:
        raise SceneError(f"{label} is {len(data):,} bytes, more than the {limit:,} bytes allowed")
    return data


def _parse_toml(content: bytes, label: str) -> dict[str, Any]:
    try:
        text = content.decode("utf-8")
    except UnicodeDecodeError:
        raise SceneError(f"{label} is not a text (TOML) scene file") from None
    try:
        document = tomllib.loads(text)
    except tomllib.TOMLDecodeError as error:
        raise SceneError(f"{label} is not valid TOML: {error}") from None
    except RecursionError:  # tomllib reads nested arrays recursively
        raise SceneError(f"{label} is nested more than {schema.MAX_DEPTH} levels "
                         "deep") from None
    schema.check_depth(document, label, error=SceneError)
    return document


def _scene_from_document(
    document: dict[str, Any], label: str, default_name: str,
    arrays_for: Callable[[int, int, int], dict[str, np.ndarray]],
    max_particles: int | None = None,
) -> Scene:
    """Build the scene a parsed TOML document describes; ``arrays_for(nx, ny, dim)`` reads the
    array file it names (called only if it names one).  A lattice of more than
    ``max_particles`` is refused before anything is built."""
    if document.get("format", FORMAT_VERSION) != FORMAT_VERSION:
        raise SceneError(
            f"{label} has format {document['format']!r}; this version reads format {FORMAT_VERSION}"
        )
    if "model" not in document or not isinstance(document["model"], dict):
        raise SceneError(f"{label} has no [model] table")
    model_table = dict(document["model"])
    unknown = set(model_table) - set(OVERRIDES)
    if unknown:
        raise SceneError(f"{label}: unknown [model] key(s) {', '.join(sorted(unknown))}")
    nx, ny, dim = _lattice_shape(model_table, label)
    if max_particles is not None and nx * ny > max_particles:
        raise SceneError(f"{label}: {nx}x{ny} = {nx * ny:,} particles, more than the "
                         f"{max_particles:,} allowed here (larger lattices run from the command "
                         "line, `oscillators run`)")
    arrays: dict[str, np.ndarray] = {}
    if "arrays" in document:
        arrays = arrays_for(nx, ny, dim)
    if isinstance(model_table.get("mass"), str):
        key = model_table["mass"].removeprefix("arrays:")
        if key not in arrays:
            raise SceneError(f"{label}: mass refers to array {key!r}, which the array file lacks")
        model_table["mass"] = arrays[key]
    try:
        model = Model.create(**model_table)
    except (ModelError, TypeError) as error:
        raise SceneError(f"{label}: {error}") from None
    try:
        positions = model.rest_positions.copy()
        if "displacements" in arrays:
            positions = positions + arrays["displacements"]
        initial = document.get("initial", {})
        rows = initial.get("displacements", []) if isinstance(initial, dict) else None
        if not isinstance(rows, list):
            raise SceneError(f"{label}: [initial] displacements must be a list of rows")
        for row in rows:
            if not isinstance(row, list) or not 2 <= len(row) <= 1 + model.dim:
                raise SceneError(
                    f"{label}: bad displacement entry {schema.shown(row)} (want [particle, dx, "
                    "dy])"
                )
            index = schema.whole_number(row[0], "a displacement's particle index", 0,
                                        model.n_particles - 1, error=SceneError)
            values = [schema.number(v, "a displacement", -1e6, 1e6, error=SceneError)
                      for v in row[1:]]
            positions[index, : len(values)] += values
        velocities = arrays.get("velocities")
        dt = schema.number(document.get("dt", 0.01), "dt", *schema.BOUNDS["dt"], low_open=True,
                           error=SceneError)
        duration = schema.number(document.get("duration", 20.0), "duration", 0.0, 1e12,
                                 low_open=True, error=SceneError)
        texts = {key: document.get(key, default) for key, default in (
            ("name", default_name), ("description", ""), ("integrator", "rk4"),
            ("precision", "float64"))}
        for key, value in texts.items():
            if not isinstance(value, str):
                raise SceneError(f"{key} must be text, got {schema.shown(value)}")
        return Scene(
            name=texts["name"], model=model, description=texts["description"],
            integrator=texts["integrator"], dt=dt, duration=duration,
            initial_positions=positions, initial_velocities=velocities,
            precision=texts["precision"],
        )
    except (ValueError, TypeError, OverflowError) as error:
        raise SceneError(f"{label}: {error}") from None


