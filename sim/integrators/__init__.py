"""The integrators: the registry (what each method is), the steppers that advance a ``State``,
their amplification matrices, and the plain numpy reference the tests compare against."""

from sim.integrators.registry import (
    ALL_INTEGRATORS,
    INTEGRATORS,
    ORDERS,
    IntegratorDescription,
    IntegratorError,
    check_integrator_name,
    check_precision,
    describe,
    descriptions,
    estimated_seconds,
    most_accurate,
    names,
)

__all__ = [
    "ALL_INTEGRATORS", "INTEGRATORS", "ORDERS", "IntegratorDescription", "IntegratorError",
    "check_integrator_name", "check_precision", "describe", "descriptions", "estimated_seconds",
    "most_accurate", "names",
]
