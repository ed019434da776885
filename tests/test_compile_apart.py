"""Kernels compiled in a child process and read from numba's cache here (``sim.runtime.warming``):
a compile refused in one thread stops before it starts, and a rehearsal whose kernels are not
cached has a child compile them, so this process compiles none."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import threading
from pathlib import Path

import numpy as np
import pytest
from numba import njit

from sim.runtime import warming

ROOT = Path(__file__).resolve().parent.parent


def test_a_refused_compile_raises_before_it_starts_in_that_thread_only():
    @njit
    def twice(values):
        return values * 2.0

    values = np.arange(3.0)
    with warming.refusing_compiles():
        with pytest.raises(warming.WouldCompile):
            twice(values)
        elsewhere = []
        thread = threading.Thread(target=lambda: elsewhere.append(twice(values)))
        thread.start()
        thread.join()
        assert np.array_equal(elsewhere[0], [0.0, 2.0, 4.0])  # another thread compiles
        assert np.array_equal(twice(values), [0.0, 2.0, 4.0])  # compiled: nothing refused
        with pytest.raises(warming.WouldCompile):
            twice(np.arange(3))  # a new type is a new compile
    assert np.array_equal(twice(np.arange(3)), [0, 2, 4])  # refused no longer


def test_a_new_thread_does_not_inherit_what_an_ended_one_with_its_identity_loaded():
    """Thread identities are given again once a thread ends: what the watch says of a thread
    is said of that thread, not of a later one that happens to get its identity."""
    @njit
    def thrice(values):
        return values * 3.0

    warming.compiles_started()  # watching from here on
    said = []

    def load() -> None:
        thrice(np.arange(3.0))
        said.append(warming.loaded_in_thread(threading.get_ident()))

    first = threading.Thread(target=load)
    first.start()
    first.join()
    assert said == [True]
    release = threading.Event()
    for _ in range(50):  # an ended thread's identity is usually the next thread's
        later = threading.Thread(target=release.wait)
        later.start()
        if later.ident == first.ident:
            break
        release.set()
        later.join()
        release.clear()
    else:
        pytest.skip("no new thread got the ended thread's identity")
    try:
        assert not warming.loaded_in_thread(later.ident)
        assert not warming.compiled_in_thread(later.ident)
    finally:
        release.set()
        later.join()


CHILD = """
import json, sys
from sim.runtime import warming
import sim
scene = sim.scenes.build("single")
compiled_apart = warming.rehearse_reading(scene, ("verlet", 0.01, "float64", 1, 5))
print(json.dumps({"apart": compiled_apart, "compiles_here": warming.compiles_started()}))
"""


def twice_on_an_empty_cache(tmp_path, *arguments: str) -> list[subprocess.CompletedProcess]:
    """Two processes ``python ARGUMENTS`` run one after the other on one numba cache, empty
    before the first."""
    environment = dict(os.environ, NUMBA_CACHE_DIR=str(tmp_path / "numba"),
                       PYTHONPATH=str(ROOT))
    return [subprocess.run([sys.executable, *arguments], capture_output=True, text=True,
                           env=environment, cwd=ROOT, timeout=600, check=True)
            for _ in range(2)]


@pytest.mark.slow
def test_a_rehearsal_of_uncached_kernels_compiles_them_in_a_child_and_none_here(tmp_path):
    runs = [json.loads(result.stdout.strip().splitlines()[-1])
            for result in twice_on_an_empty_cache(tmp_path, "-c", CHILD)]
    assert runs[0] == {"apart": True, "compiles_here": 0}  # the child compiled, this read
    assert runs[1] == {"apart": False, "compiles_here": 0}  # all in the cache now


@pytest.mark.slow
def test_a_first_run_says_it_compiles_in_a_child_and_a_second_run_does_not(tmp_path):
    said = ["compiling the kernels for this run in a child process" in result.stdout + result.stderr
            for result in twice_on_an_empty_cache(tmp_path, "-m", "app.cli", "run", "single",
                                                  "--steps", "20", "--quiet")]
    assert said == [True, False]


def test_an_unpickled_model_keeps_its_arrays_read_only():
    """A child compiling kernels gets the scene pickled; a writable array would be another
    type, so the child would compile kernels this process does not run."""
    import pickle

    import sim

    model = sim.scenes.build("grid", nx=12, ny=12).model.replace(boundary="absorbing")
    copy = pickle.loads(pickle.dumps(model))
    assert not copy.masses.flags.writeable
    assert np.array_equal(copy.masses, model.masses) and copy.boundary == "absorbing"
