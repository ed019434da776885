"""Module-level calls for ``sim.runtime.children.call_in_child`` to run in child processes
(tests/test_kernel_preparing.py): each appends what it did to a file."""

import time

from sim.runtime.children import signal_ready, wait_for_end


def _note(path: str, text: str) -> None:
    with open(path, "a", encoding="utf-8") as file:
        file.write(text + "\n")


def main_side(path: str, fail: bool = False, loop_done: int | None = None,
              layer_ready: int | None = None) -> None:
    if fail:
        raise SystemExit(5)
    wait_for_end(layer_ready)
    _note(path, "main: after the other's first part")
    wait_for_end(loop_done)
    _note(path, "main: after the other ended")


def beside_side(path: str, fail: bool = False, layer_ready: int | None = None) -> None:
    if fail:
        raise SystemExit(3)
    time.sleep(0.3)
    _note(path, "beside: first part")
    signal_ready(layer_ready)
    time.sleep(0.3)
    _note(path, "beside: the rest")
