"""Module-level calls for ``sim.runtime.children.call_in_child`` to run in child processes
(tests/test_kernel_preparing.py): each appends what it did to a file."""

import time

from sim.runtime.children import signal_ready, wait_for_end


def _note(path: str, text: str) -> None:
    with open(path, "a", encoding="utf-8") as file:
        file.write(text + "\n")


def main_side(path: str, fail: bool = False, loop_done: int | None = None,
              forces_ready: int | None = None) -> None:
    time.sleep(0.3)
    _note(path, "main: forces")
    if fail:
        raise SystemExit(5)
    signal_ready(forces_ready)
    wait_for_end(loop_done)
    _note(path, "main: after the loop")


def beside_side(path: str, fail: bool = False, forces_ready: int | None = None) -> None:
    if fail:
        raise SystemExit(3)
    wait_for_end(forces_ready)
    time.sleep(0.3)
    _note(path, "beside: loop")
