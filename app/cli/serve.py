"""``oscillators serve``: start the web app (``app.web.app.WebApp``) on a scene and print its
address; checks the host, the allowed origins and the scene directory before it starts.
"""

from __future__ import annotations

import argparse
import ipaddress
import os
import signal
import socket
import sys
import threading
import time
from pathlib import Path

from app.cli.arguments import add_scene_arguments, simulation_from_arguments
from app.cli.commands import summary
from sim.scenes.presets import PRESETS

EPILOG = """examples:
  oscillators serve                          # the 12x8 grid on http://127.0.0.1:8080
  oscillators serve catenary --play          # start running at once
  oscillators serve interference             # 682x383 particles, the displacement field
  oscillators serve grid --set nx=25 --set ny=20 --integrator verlet
  oscillators serve my_scene.toml            # a saved scene file
  oscillators serve --host 0.0.0.0 --port 8000   # let a classroom connect to this machine
  oscillators serve --scenes-dir lessons/        # offer the .toml files in lessons/ by name
  oscillators serve interference --host 0.0.0.0 --class   # a class: only the teacher drives

in the page: click a particle to select it (shift+click adds), drag the arrows to move it,
press Play; the panel changes integrator, time step, stiffness, damping, gravity and more.

files: the page never names a file on this machine.  "Download this scene" saves to the
browser, "Open a scene file" uploads one from it, and the scene files in --scenes-dir are
offered by name.  Recordings started in the page go to --recordings-dir.

a class (--class): a page opened on this machine, or with the teacher link printed at start, is
the teacher and drives the run; every other page is a student (whenever it connects, and again
when it reconnects): it watches the run, the plots and read-outs with the shared controls greyed
out, moves its own camera and follows a particle of its own (click one), and the server refuses
anything else it sends.  --teacher-token keeps the teacher link the same across restarts.

security: only pages served by this server drive it (the websocket checks the Origin and Host
headers); --allow-origin admits another page (e.g. behind a proxy).  Binding stays on this
machine (127.0.0.1) unless you pass --host; anyone who can then reach the port controls the app.
"""


def register(subparsers: argparse._SubParsersAction) -> None:
    """Add the ``serve`` command to ``oscillators``."""
    parser = subparsers.add_parser(
        "serve", help=summary("serve"),
        description="Start a viser web server showing the lattice live. Open the printed "
        "address in a browser; every browser connected sees (and controls) the same lattice.",
        epilog=EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    add_scene_arguments(parser, default_scene="grid")
    parser.add_argument("--host", default="127.0.0.1",
                        help="address to listen on (default 127.0.0.1, this machine only; "
                        "0.0.0.0 for every network interface)")
    parser.add_argument("--port", type=_port, default=8080,
                        help="port (default 8080; if it is taken, the next free one is used)")
    parser.add_argument("--play", action="store_true", help="start running immediately")
    parser.add_argument("--scenes-dir", default="scenes", metavar="DIR",
                        help="directory whose .toml scene files the page offers by name "
                        "(default ./scenes; nothing outside it is ever opened)")
    parser.add_argument("--recordings-dir", metavar="DIR",
                        help="an existing directory where recordings started in the page are "
                        "written (default ./recordings, made at the first recording)")
    parser.add_argument("--allow-origin", action="append", default=[], metavar="ORIGIN",
                        help="also let pages from ORIGIN (http://name:port) drive the app, or "
                        "'*' for any page (repeatable; default: only this server's own page)")
    parser.add_argument("--class", dest="class_mode", action="store_true",
                        help="teach a class: pages on this machine and the teacher link printed "
                        "drive the run, every other page only watches")
    parser.add_argument("--teacher-token", default=None, metavar="TOKEN",
                        help="with --class: the teacher link's token (letters, digits, - and _, "
                        "at least 16), so the link stays the same when the server restarts "
                        "(default: a new random one each start)")
    parser.add_argument("--no-warm", action="store_true",
                        help="do not compile the other presets' kernels in the background "
                        "(by default a low-priority process does, this scene's Physics "
                        "toggles first, so the page seldom waits for a compile)")
    parser.set_defaults(handler=command_serve, reads_cached_kernels=True)


def _port(text: str) -> int:
    try:
        port = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"a port is a whole number, got {text!r}") from None
    if not 0 <= port <= 65535:
        raise argparse.ArgumentTypeError(f"a port is between 0 and 65535, got {port}")
    return port


def check_host(host: str) -> None:
    """Raise ValueError with a clear message unless this machine can listen on ``host``."""
    try:
        infos = socket.getaddrinfo(host, 0, type=socket.SOCK_STREAM)
    except socket.gaierror as error:
        raise ValueError(f"--host {host!r} is not an address of this machine ({error})") from None
    family, kind, protocol, _, address = infos[0]
    with socket.socket(family, kind, protocol) as probe:
        try:
            probe.bind(address)
        except OSError as error:
            raise ValueError(
                f"cannot listen on --host {host!r}: {error.strerror or error}"
            ) from None


def _teacher_token(text: str | None) -> str | None:
    """A ``--teacher-token``: at least 16 letters, digits, ``-`` or ``_`` (it goes in a URL)."""
    if text is None:
        return None
    if len(text) < 16 or not all(c.isascii() and (c.isalnum() or c in "-_") for c in text):
        raise ValueError("--teacher-token wants at least 16 letters, digits, '-' or '_'")
    return text


def _loopback(host: str) -> bool:
    """Whether ``host`` only listens on this machine (127.0.0.0/8, ::1, localhost)."""
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


SHUTDOWN_SECONDS = 4.5
"""Longest a stop (Ctrl+C, SIGTERM) may take before the process exits anyway: a running
recording is closed first; one whose closing takes longer keeps its readable ``.partial``."""


def _exit_if_stuck(seconds: float) -> None:
    """Exit the process ``seconds`` from now if stopping has not finished by then."""

    def watchdog() -> None:
        time.sleep(seconds)
        print(f"stopping took more than {seconds:g} s; exiting now", file=sys.stderr, flush=True)
        os._exit(1)

    threading.Thread(target=watchdog, name="shutdown-watchdog", daemon=True).start()


def command_serve(arguments: argparse.Namespace) -> int:
    from app.web.app import WebApp
    from app.web.security import check_origins, network_warning

    check_host(arguments.host)
    check_origins(arguments.allow_origin)
    scenes_dir = Path(arguments.scenes_dir)
    if scenes_dir.exists() and not scenes_dir.is_dir():
        raise ValueError(f"--scenes-dir {scenes_dir} is not a directory")
    if arguments.recordings_dir is None:
        arguments.recordings_dir = "recordings"
    elif not Path(arguments.recordings_dir).is_dir():
        raise ValueError(f"--recordings-dir {arguments.recordings_dir} is not an existing "
                         "directory; make it first (the server creates no folders)")
    simulation = simulation_from_arguments(arguments)
    app = WebApp(simulation, host=arguments.host, port=arguments.port, play=arguments.play,
                 scenes_dir=scenes_dir, recordings_dir=arguments.recordings_dir,
                 allow_origins=arguments.allow_origin, class_mode=arguments.class_mode,
                 teacher_token=_teacher_token(arguments.teacher_token))

    def terminate(number: int, frame: object) -> None:  # SIGTERM: stop as Ctrl+C does
        raise KeyboardInterrupt

    # installed before anything is printed, so a SIGTERM right after the first line stops cleanly
    previous = signal.signal(signal.SIGTERM, terminate)
    warming = None
    try:
        app.start()
        if not arguments.no_warm:
            from app.cli.warm import start_background

            preset = simulation.scene.name if simulation.scene.name in PRESETS else None
            warming = start_background(preset)
        print(f"{simulation.scene.summary()}")
        print(f"serving on {app.url}  (Ctrl+C to stop)", flush=True)
        print(f"scene files offered from {scenes_dir}/ ({len(app.scene_files.names())} found); "
              f"recordings go to {arguments.recordings_dir}/", flush=True)
        if warming is not None:
            print("compiling the other presets' kernels in the background at low priority "
                  "(--no-warm: not)", flush=True)
        if not _loopback(arguments.host) and app.roles is not None:
            print(f"warning: listening on {arguments.host}: anyone who can reach this machine on "
                  f"port {app.server.get_port()} can open the page and watch; only teacher pages "
                  "drive the run, open scene files and record", file=sys.stderr, flush=True)
        elif not _loopback(arguments.host):
            print(network_warning(arguments.host, app.server.get_port(), str(scenes_dir),
                                  str(arguments.recordings_dir)), file=sys.stderr, flush=True)
        if not _loopback(arguments.host):
            print("others open http://<this machine's address>:"
                  f"{app.server.get_port()}", flush=True)
        if app.roles is not None:
            from app.web.join import join_url, qr_text

            print(f"class: pages on this machine drive the run, and so does the teacher link "
                  f"{app.roles.teacher_link(app.url)}  (keep it to yourself); every other page "
                  f"only watches (see it as a student: {app.roles.student_link(app.url)})",
                  flush=True)
            address = None if not _loopback(arguments.host) else "127.0.0.1"
            app.roles.join_url = join_url(app.server.get_port(), address)
            print(f"students join at {app.roles.join_url} (on the teacher's page too, with this "
                  f"code):\n{qr_text(app.roles.join_url)}", flush=True)
        while True:
            time.sleep(1.0)
    except KeyboardInterrupt:
        print("stopping", flush=True)
        _exit_if_stuck(SHUTDOWN_SECONDS)
    finally:
        if warming is not None:
            from app.cli.warm import stop_background

            stop_background(warming)
        app.stop()  # closes a running recording so that its file verifies
        signal.signal(signal.SIGTERM, previous)
    # everything is closed: skip the interpreter's own teardown, where the libraries' threads
    # can take seconds to wind down (one SIGTERM stops the server within 5 s)
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(0)
