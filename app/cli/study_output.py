"""What the study commands (accuracy, stability, dispersion, response, reflection) share: the
output options (--json, --plot PATH.png, --quiet and, where a picture is saved by default (in
the folder ``pictures``, never the current folder itself), --no-plot), the check of the
picture's path before a long study runs, the progress bar on stderr and printing the report (a
table, or JSON).
"""

from __future__ import annotations

import argparse
import json
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

from sim.model.schema import printable
from sim.storage.files import AtomicFile, safe_name

DEFAULT_PICTURES_DIR = Path("pictures")
"""Where a study's picture goes without --plot (made when missing): its own folder, never the
current one itself."""


def add_output_arguments(parser: argparse.ArgumentParser, picture: str | None = None) -> None:
    """--json, --plot, --quiet; with ``picture`` (the default file name, as the help shows it,
    e.g. ``SCENE-response.png``) also --no-plot."""
    parser.add_argument("--json", action="store_true", help="print the results as JSON")
    parser.add_argument("--plot", metavar="PATH.png", help="save the picture to this PNG file")
    parser.add_argument("--quiet", action="store_true", help="no progress bar")
    if picture is not None:
        parser.add_argument("--no-plot", action="store_true",
                            help=f"do not save the picture (by default it goes to "
                            f"{DEFAULT_PICTURES_DIR / picture}, the folder made when missing, "
                            "or to --plot)")


def scene_picture(scene: Any, kind: str) -> str:
    """The default picture's name of a study of ``scene``: ``grid-response.png`` (a scene file's
    name without its suffix), in ``DEFAULT_PICTURES_DIR``."""
    return f"{safe_name(Path(str(scene.name)).stem)}-{kind}.png"


def default_plot(arguments: argparse.Namespace, name: str) -> None:
    """The picture goes to --plot, or to ``name`` in ``DEFAULT_PICTURES_DIR`` (made when
    missing) unless --no-plot; checked."""
    if arguments.no_plot:
        arguments.plot = None
    elif not arguments.plot:
        DEFAULT_PICTURES_DIR.mkdir(exist_ok=True)
        arguments.plot = str(DEFAULT_PICTURES_DIR / name)
    check_plot_path(arguments)


def check_plot_path(arguments: argparse.Namespace) -> None:
    """--plot must name a PNG file in an existing directory: checked before a long study runs."""
    if not arguments.plot:
        return
    path = Path(arguments.plot)
    if path.suffix.lower() != ".png":
        raise ValueError(f"--plot takes a .png file name, got {arguments.plot}")
    if path.is_dir():
        raise ValueError(f"--plot {arguments.plot} is a directory; give a .png file name")
    if not path.parent.is_dir():
        raise ValueError(f"--plot {arguments.plot}: the directory {path.parent} does not exist")


def progress_bar(total: int | None, quiet: bool):
    """A tqdm bar counting runs on stderr (``total`` None: unknown), off with ``quiet``."""
    from tqdm import tqdm

    return tqdm(total=total, unit="run", disable=quiet, dynamic_ncols=True, file=sys.stderr)


def advance(bar) -> Callable[[str], None]:
    """The ``progress(label)`` callback of a study: one more run done, labelled."""

    def progress(label: str) -> None:
        if bar.total is not None and bar.n >= bar.total:
            bar.total = bar.n + 1
        bar.set_description(label)
        bar.update(1)

    return progress


def emit(arguments: argparse.Namespace, data: dict[str, Any], text: str) -> None:
    """Print the study: ``data`` as JSON with --json, else ``text`` and where the picture went."""
    if arguments.json:
        print(json.dumps(data, indent=2))
    else:
        print(printable(text))
        if arguments.plot:
            print(f"picture saved to {Path(arguments.plot).resolve()}")


def write_picture(path: str, plot: Callable[[Any, str], None], study: Any) -> None:
    """Draw ``study`` with ``plot`` into ``path`` (a PNG) through ``sim.storage.files.AtomicFile``: an
    exclusive temporary file beside it, renamed when the picture is complete.  ``plot`` draws
    into a private temporary folder first (it may name and write files as it likes there)."""
    import tempfile

    with AtomicFile(path, overwrite=True) as output, \
            tempfile.TemporaryDirectory(prefix="oscillators-picture-") as folder:
        drawn = Path(folder) / Path(path).name
        plot(study, str(drawn))
        output.file.write(drawn.read_bytes())


def save_picture(arguments: argparse.Namespace, data: dict[str, Any],
                  plot: Callable[[Any, str], None], study: Any) -> None:
    """Draw ``study`` with ``plot`` to --plot, if any, and name the file in ``data``."""
    if arguments.plot:
        write_picture(arguments.plot, plot, study)
        data["picture"] = str(Path(arguments.plot).resolve())
