"""The ``oscillators serve`` subcommand: start the web app on a scene and print its address.

``register(subparsers)`` is called by ``app.cli`` when it builds the command line.
"""

from __future__ import annotations

import argparse
import socket
import time

EPILOG = """examples:
  oscillators serve                          # the 12x8 grid on http://127.0.0.1:8080
  oscillators serve catenary --play          # start running at once
  oscillators serve interference             # 682x383 particles, the displacement field
  oscillators serve grid --set nx=25 --set ny=20 --integrator verlet
  oscillators serve my_scene.toml            # a saved scene file
  oscillators serve --host 0.0.0.0 --port 8000   # let a classroom connect to this machine

in the page: click a particle to select it (shift+click adds), drag the arrows to move it,
press Play; the panel changes integrator, time step, stiffness, damping, gravity and more.
"""


def register(subparsers: argparse._SubParsersAction) -> None:
    from app.cli import add_scene_arguments

    parser = subparsers.add_parser(
        "serve", help="the web app: watch and play with a lattice in the browser",
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
    parser.set_defaults(handler=command_serve)


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


def command_serve(arguments: argparse.Namespace) -> int:
    from app.cli import simulation_from_arguments
    from app.web.app import WebApp

    check_host(arguments.host)
    simulation = simulation_from_arguments(arguments)
    app = WebApp(simulation, host=arguments.host, port=arguments.port, play=arguments.play)
    app.start()
    print(f"{simulation.scene.summary()}")
    print(f"serving on {app.url}  (Ctrl+C to stop)", flush=True)
    if arguments.host in ("0.0.0.0", "::"):
        print("listening on every network interface: others open http://<this machine>:"
              f"{app.server.get_port()}", flush=True)
    try:
        while True:
            time.sleep(1.0)
    except KeyboardInterrupt:
        print("stopping", flush=True)
    finally:
        app.stop()
    return 0
