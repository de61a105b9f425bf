"""One-line input errors that name the field, the value and the rule.

Every check raises :class:`InvalidValue`, a :class:`ValueError`, with a message of the form
``"mass_kg = -1.0: must be > 0 and finite"`` so the CLI can print it as it is and exit 2. An
engine adapter that validates the user's engine parameters with these checks inside a run
raises the same type, which :func:`impactbench.engines.base.run_safely` hands on as bad input
(not a ``crashed`` run).
"""

from __future__ import annotations

import math
from numbers import Real


class InvalidValue(ValueError):
    """A value that breaks its field's rule (the message names both): bad input."""


def _number(field: str, value: object) -> float:
    if isinstance(value, bool) or not isinstance(value, Real):
        raise InvalidValue(f"{field} = {value!r}: must be a real number")
    return float(value)


def positive(field: str, value: object) -> float:
    """Return ``value`` as float; raise unless it is finite and > 0."""
    v = _number(field, value)
    if not (math.isfinite(v) and v > 0.0):
        raise InvalidValue(f"{field} = {value!r}: must be > 0 and finite")
    return v


def non_negative(field: str, value: object) -> float:
    """Return ``value`` as float; raise unless it is finite and ≥ 0."""
    v = _number(field, value)
    if not (math.isfinite(v) and v >= 0.0):
        raise InvalidValue(f"{field} = {value!r}: must be >= 0 and finite")
    return v


def finite(field: str, value: object) -> float:
    """Return ``value`` as float; raise unless it is finite."""
    v = _number(field, value)
    if not math.isfinite(v):
        raise InvalidValue(f"{field} = {value!r}: must be finite")
    return v


def one_of(field: str, value: object, choices: tuple[str, ...]) -> str:
    """Return ``value``; raise unless it is one of ``choices`` (with a did-you-mean hint)."""
    if value in choices:
        return str(value)
    import difflib

    hint = difflib.get_close_matches(str(value), choices, n=1)
    extra = f" (did you mean {hint[0]!r}?)" if hint else ""
    raise InvalidValue(f"{field} = {value!r}: must be one of {', '.join(choices)}{extra}")
