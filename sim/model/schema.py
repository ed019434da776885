"""The one set of checks every value from outside passes: scene files, ``--set`` and the page.

Types are exact: a number is an ``int`` or ``float`` (numpy scalars included), never a string
or a boolean; a whole number (a size, an index) is an integer or a float with no fractional
part, never rounded; a choice is one of its strings.  Numbers are finite and inside their bounds
(``BOUNDS`` holds those of the lattice parameters, wide enough for any physical lattice and
narrow enough that every quantity derived from them, energies and frequencies included, stays
finite in float64).  A parsed document may nest at most ``MAX_DEPTH`` levels.

Every check raises ``Refused`` (a ``ValueError``) or the error class the caller passes, with a
one-line message naming the value: ``sim.model.ModelError`` for the lattice,
``app.web.inputs.InputRefused`` for the page.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Sequence
from typing import Any

from sim.model import parameters

MAX_DEPTH = 16
"""Deepest nesting of tables and arrays a scene document may have (a scene needs 4)."""


class Refused(ValueError):
    """A value from outside was refused (the message says which and why, in one line)."""


BOUNDS: dict[str, tuple[float, float]] = {
    **parameters.bounds(), "dt": (0.0, 1e6), "amplitude": (0.0, 1e6)}
"""(smallest, largest) of each number parameter of a scene (SI units, read from the parameter
table ``sim.model.parameters``), of a time step (s, the smallest excluded) and of a driver's
amplitude (m)."""


def _is_number(value: Any) -> bool:
    return isinstance(value, numbers.Real) and not isinstance(value, bool)


def number(value: Any, name: str, low: float = -math.inf, high: float = math.inf, *,
           low_open: bool = False, error: type[Exception] = Refused) -> float:
    """``value`` as a finite float in [low, high] (or (low, high] with ``low_open``); a string,
    a boolean, None or anything else that is not a number is refused."""
    if not _is_number(value):
        raise error(f"{name} must be a number, got {shown(value)}")
    result = float(value)
    if not math.isfinite(result):
        raise error(f"{name} must be a finite number, got {result!r}")
    below = result <= low if low_open else result < low
    if below or result > high:
        bracket = "(" if low_open else "["
        raise error(f"{name} must be in {bracket}{low:g}, {high:g}], got {result:g}")
    return result


def parameter(value: Any, name: str, *, error: type[Exception] = Refused) -> float:
    """A lattice parameter within its ``BOUNDS`` (a zero lower bound is closed, others open)."""
    low, high = BOUNDS[name]
    return number(value, name, low, high, error=error)


def whole_number(value: Any, name: str, low: int = 0, high: float = math.inf, *,
                 error: type[Exception] = Refused) -> int:
    """``value`` as an int in [low, high]; a fractional number is refused, not rounded."""
    if not _is_number(value):
        raise error(f"{name} must be a whole number, got {shown(value)}")
    result = float(value)
    if not math.isfinite(result) or not result.is_integer():
        raise error(f"{name} must be a whole number, got {shown(value)}")
    if result < low or result > high:
        upper = "" if high == math.inf else f" and at most {high:g}"
        raise error(f"{name} must be at least {low}{upper}, got {int(result)}")
    return int(result)


def choice(value: Any, name: str, options: Sequence[str], *,
           error: type[Exception] = Refused) -> str:
    """``value`` if it is one of the strings ``options``."""
    if not isinstance(value, str) or value not in options:
        raise error(f"{name} must be one of {', '.join(options)}; got {shown(value)}")
    return value


def flag(value: Any, name: str, *, error: type[Exception] = Refused) -> bool:
    """``value`` if it is a boolean (true/false)."""
    if not isinstance(value, bool) and type(value).__name__ != "bool_":
        raise error(f"{name} must be true or false, got {shown(value)}")
    return bool(value)


def finite(value: float, name: str, *, error: type[Exception] = Refused) -> float:
    """A derived quantity (an energy scale, a frequency): refused, not warned about, when the
    parameters make it overflow."""
    if not math.isfinite(value):
        raise error(f"these parameters make {name} overflow; use smaller values")
    return value


def check_depth(document: Any, label: str, limit: int = MAX_DEPTH, *,
                error: type[Exception] = Refused) -> None:
    """Refuse a parsed document (dicts and lists) nested deeper than ``limit`` (iteratively:
    a deep document cannot exhaust the stack here)."""
    pending: list[tuple[Any, int]] = [(document, 1)]
    while pending:
        item, depth = pending.pop()
        if depth > limit:
            raise error(f"{label} is nested more than {limit} levels deep")
        if isinstance(item, dict):
            pending.extend((child, depth + 1) for child in item.values())
        elif isinstance(item, (list, tuple)):
            pending.extend((child, depth + 1) for child in item)


_INVISIBLE = {0x2028, 0x2029, *range(0x202A, 0x202F), *range(0x2066, 0x206A), 0x200E, 0x200F}


def printable(text: str, keep: str = "\n\t") -> str:
    """``text`` safe to print on a terminal: control characters (escape sequences that would
    retitle or clear it, carriage returns, bidirectional overrides) are shown as ``\\xNN`` /
    ``\\uNNNN``; the characters in ``keep`` stay."""
    out = []
    for character in str(text):
        code = ord(character)
        if character in keep or not (code < 0x20 or 0x7F <= code < 0xA0 or code in _INVISIBLE):
            out.append(character)
        elif code < 0x100:
            out.append(f"\\x{code:02x}")
        else:
            out.append(f"\\u{code:04x}")
    return "".join(out)


def key_values(text: str, what: str, *, error: type[Exception] = Refused) -> list[tuple[str, str]]:
    """The (key, value) pairs of a command line's "key=value,key=value" ``text`` (blank parts
    skipped, both sides stripped); a part without "=" is refused, naming ``what``."""
    pairs = []
    for part in text.split(","):
        part = part.strip()
        if not part:
            continue
        if "=" not in part:
            raise error(f"{what} fields are key=value, got {shown(part)} in {shown(text)}")
        key, raw = (item.strip() for item in part.split("=", 1))
        pairs.append((key, raw))
    return pairs


def shown(value: Any, limit: int = 60) -> str:
    """``repr(value)`` cut to ``limit`` characters, control characters escaped."""
    text = repr(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."
