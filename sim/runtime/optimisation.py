"""numba's optimisation before inlining, so that a kernel compiled in the running process runs
as fast as one read from numba's cache (the one module that reaches into numba's code generator).

numba compiles each function into a library of its own and links copies of its callees into the
caller.  At its default level a library's module gets a cheap pass at level 0, which inlines
nothing, then the full level-3 pass: the reference-counting calls of the small functions a row
loop calls (``spring_force``, ``kick_drift``) reach the loop only during that pass, after its
loop vectorizer has passed it over, so a library's own row loop stays scalar.  A kernel read from
the cache runs its own (vectorised) copies of its callees; a kernel compiled in the running process
is bound to the callees' scalar libraries loaded before it, 2-5 times slower for as long as the
process lives (``docs/web.md``, "Compiled apart").  ``NUMBA_OPT=max`` runs the cheap pass at level
3 with loop vectorisation, so every library's loops vectorise on their own, at about a sixth more
compile time.

``optimise_before_inlining`` sets it when ``sim`` is imported, before numba compiles anything,
unless the user set ``NUMBA_OPT`` (kept as it is: the test suite's level 1) or
``OSCILLATORS_NUMBA_OPT=0``.  The command line and the page compile their kernels in a child
process and read them from the cache at numba's default level, where the fused leapfrog runs
about a tenth faster than at ``max``: they call ``use_numba_default`` first
(``app.cli``).  The level is set as the environment variable, not as numba's ``config.OPT``
alone: numba re-reads every ``NUMBA_*`` variable when one changes, and child processes inherit
it; a code generator numba has already made is switched too.
"""

from __future__ import annotations

import os
import sys

SETTING = "OSCILLATORS_NUMBA_OPT"
"""``0``: leave numba's level as it is (its default, or the user's ``NUMBA_OPT``)."""
_OURS = "_OSCILLATORS_SET_NUMBA_OPT"
"""Set beside ``NUMBA_OPT`` when this module set it (so ``use_numba_default`` may take it back)."""


def _apply(level: int, vectorise: bool) -> None:
    """Have numba read the environment again and switch a code generator it already made to the
    cheap pass's ``level``; nothing when numba is not imported yet (it reads the variable when
    it makes its code generator)."""
    if "numba" not in sys.modules:
        return
    from numba.core import config

    config.reload_config()
    try:
        from numba.core.registry import cpu_target

        if "_toplevel_target_context" in vars(cpu_target):  # a code generator exists already
            codegen = cpu_target.target_context.codegen()
            codegen._opt_level, codegen._loopvect = level, vectorise
    except (ImportError, AttributeError):  # numba's internals moved: new code generators still
        pass  # read NUMBA_OPT (tests/test_compile_levels.py notices)


def optimise_before_inlining() -> bool:
    """Set numba's level to ``max`` unless the user chose a level or ``OSCILLATORS_NUMBA_OPT=0``;
    returns whether it did."""
    if os.environ.get(SETTING, "1") == "0" or "NUMBA_OPT" in os.environ:
        return False
    os.environ["NUMBA_OPT"] = "max"
    os.environ[_OURS] = "1"
    _apply(3, True)
    return True


def use_numba_default() -> None:
    """Back to numba's default level for this process and its children, before anything is
    compiled: for a process that compiles in a child and reads the cache (``sim.runtime.warming``).
    A ``NUMBA_OPT`` the user set stays."""
    os.environ[SETTING] = "0"
    if os.environ.pop(_OURS, None) is not None:
        os.environ.pop("NUMBA_OPT", None)
        _apply(0, False)
        from sim.runtime.kernel_cache import follow_level

        follow_level()  # the kernels made at import look in the default level's folder


OPTIMISED_BEFORE_INLINING = optimise_before_inlining()
