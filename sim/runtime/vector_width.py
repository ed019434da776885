"""Let numba's compiler use the CPU's full vector width (512-bit AVX-512) where it has one.

LLVM prefers 256-bit vectors even on CPUs with AVX-512, and numba compiles for the host CPU with
LLVM's defaults.  The spring sweep is compute-bound, and on this project's CI-class machine
(an AVX-512 Xeon) 512-bit vectors made velocity Verlet about 20 % and RK4 about 16 % faster on
682x383 (``oscillators bench``).  This module sets numba's documented ``NUMBA_CPU_NAME`` /
``NUMBA_CPU_FEATURES`` to the host's own CPU and features minus ``prefer-256-bit`` -- only when
the host has AVX-512F, only when the user has not set them, and never when
``OSCILLATORS_WIDE_VECTORS=0``.  It must run before numba compiles anything; ``sim/__init__.py``
imports it first.
"""

from __future__ import annotations

import os
import sys


def enable_wide_vectors() -> bool:
    """Configure numba for 512-bit vectors if possible; returns whether it did."""
    if os.environ.get("OSCILLATORS_WIDE_VECTORS", "1") == "0":
        return False
    if "NUMBA_CPU_NAME" in os.environ or "NUMBA_CPU_FEATURES" in os.environ:
        return False
    try:
        import llvmlite.binding as llvm

        features = llvm.get_host_cpu_features().flatten()
        name = llvm.get_host_cpu_name()
    except Exception:  # no host information: keep numba's defaults
        return False
    if "+avx512f" not in features.split(","):
        return False
    os.environ["NUMBA_CPU_NAME"] = name
    os.environ["NUMBA_CPU_FEATURES"] = features + ",-prefer-256-bit"
    if "numba" in sys.modules:
        from numba.core import config

        config.reload_config()
    return True


WIDE_VECTORS = enable_wide_vectors()


def vector_width_bits() -> int:
    """Width of the vectors the compiled kernels use on this host: 512 with AVX-512 (when enabled
    above), 256 with AVX/AVX2, else 128."""
    if WIDE_VECTORS:
        return 512
    try:
        import llvmlite.binding as llvm

        features = set(llvm.get_host_cpu_features().flatten().split(","))
    except Exception:
        return 128
    return 256 if "+avx2" in features or "+avx" in features else 128
