"""The knobs of every fit: :class:`Knob` (one searched quantity) and :class:`KnobSpace` (knobs
searched together, in unit coordinates), the engine layer's so that an engine's tuning spaces
live beside its adapter (:mod:`~impactbench.engines.tuning_spaces`,
:mod:`~impactbench.engines.oblique_tuned`, :mod:`~impactbench.engines.cube_toss_spaces`).
The one tuner (:mod:`impactbench.tuning.search`) searches them and re-exports both names.

A knob is absolute (bounds and start fixed numbers, what the tuner searches) or relative to a
scenario (the oblique impact's friction knobs): bounds in multiples of the scenario's μ or of
the start (``per``), a start that is a function of the scenario and the step. A relative knob
is made absolute by :meth:`Knob.resolve` before it is searched.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from impactbench.reference import validation as check

PER = ("", "friction", "start")
"""What a knob's bounds are multiples of: nothing (absolute), the scenario's μ, its start."""


def scenario_friction(scenario: Any, dt: float | None) -> float:
    """A knob's start that is the scenario's μ (``initial=scenario_friction``)."""
    return float(scenario.friction)


@dataclass(frozen=True)
class Knob:
    """One searched quantity: a number in [low, high], searched in ln when ``log``, or one of
    ``choices``. ``initial`` is the start; None: the middle of the box (the geometric mean of a
    log knob), a categorical's first choice. ``unit`` and ``note`` describe it (``name`` is the
    engine's own key where the knob is one).

    Relative knobs (module doc): ``per`` (:data:`PER`) scales ``low`` and ``high`` by the
    scenario's μ or by the start value, and ``initial`` may be a function
    ``(scenario, dt) -> value``; :meth:`start_value`, :meth:`bounds` and :meth:`resolve`
    evaluate them for a scenario and step."""

    name: str
    low: float = math.nan
    high: float = math.nan
    log: bool = True
    choices: tuple[Any, ...] = ()
    unit: str = ""
    note: str = ""
    initial: Any = None
    per: str = ""

    def __post_init__(self) -> None:
        check.one_of(f"knob {self.name}: per", self.per, PER)

    @property
    def scale(self) -> str:
        """``choice``, ``log`` or ``linear``."""
        return "choice" if self.choices else ("log" if self.log else "linear")

    @property
    def relative(self) -> bool:
        """True when the bounds or the start depend on the scenario (:meth:`resolve`)."""
        return bool(self.per) or callable(self.initial)

    @property
    def start(self) -> Any:
        if callable(self.initial):
            raise ValueError(f"knob {self.name}: its start depends on the scenario "
                             "(start_value(scenario, dt))")
        if self.initial is not None:
            return self.initial
        if self.choices:
            return self.choices[0]
        return math.sqrt(self.low * self.high) if self.log else 0.5 * (self.low + self.high)

    def start_value(self, scenario: Any, dt: float | None) -> Any:
        """The start for ``scenario`` at step ``dt`` (a relative knob's function evaluated)."""
        if callable(self.initial):
            return self.initial(scenario, dt)
        return self.start

    def bounds(self, scenario: Any, dt: float | None) -> tuple[float, float]:
        """The absolute search box for ``scenario`` at step ``dt`` (NaN, NaN for a choice)."""
        if self.choices:
            return math.nan, math.nan
        if not self.per:
            return self.low, self.high
        unit = (float(scenario.friction) if self.per == "friction"
                else float(self.start_value(scenario, dt)))
        return self.low * unit, self.high * unit

    def resolve(self, scenario: Any, dt: float | None) -> Knob:
        """The absolute knob for ``scenario`` at step ``dt``: its box and start evaluated."""
        lo, hi = self.bounds(scenario, dt)
        return replace(self, low=lo, high=hi, initial=self.start_value(scenario, dt), per="")

    def summary(self, scenario: Any, dt: float | None) -> str:
        """The knob in one line for ``scenario`` at ``dt`` (an oblique tuned file's
        ``[space]``)."""
        start = self.start_value(scenario, dt)
        if self.choices:
            return (f"choice of {', '.join(repr(c) for c in self.choices)}; start {start!r}; "
                    f"{self.note}")
        lo, hi = self.bounds(scenario, dt)
        per = {"": "", "friction": f" ({self.low:g}–{self.high:g} × μ)",
               "start": f" ({self.low:g}–{self.high:g} × start)"}[self.per]
        return f"{self.scale} in [{lo:.6g}, {hi:.6g}]{per}; start {start:.6g}; {self.note}"

    def check(self, value: Any, engine: str) -> Any:
        """A given value of this key validated (one-line ValueError naming ``tuned.name``):
        one of the choices, a positive number (log) or a non-negative one (linear)."""
        name = f"tuned.{self.name}"
        if self.choices:
            for c in self.choices:  # 1 == True in Python: match the type too
                if value == c and type(value) is type(c):
                    return c
                if isinstance(c, int) and not isinstance(c, bool) and isinstance(value, float) \
                        and value == c:
                    return c
            raise ValueError(f"{name} = {value!r}: must be one of "
                             f"{', '.join(repr(c) for c in self.choices)} ({engine})")
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise ValueError(f"{name} = {value!r}: must be a number ({engine})")
        if self.log:
            return check.positive(name, float(value))
        return check.non_negative(name, float(value))

    def describe(self) -> dict[str, Any]:
        """The knob as a table (a tuned file's ``[space]``)."""
        if self.choices:
            return {"name": self.name, "choices": list(self.choices), "start": self.start,
                    "note": self.note}
        return {"name": self.name, "low": self.low, "high": self.high, "scale": self.scale,
                "start": self.start, "unit": self.unit, "note": self.note}

    def from_unit(self, u: float) -> float:
        """The value at unit coordinate ``u`` ∈ [0, 1] (clipped; the result kept in the box:
        exp(log(high)) may round past it)."""
        lo, hi = self.low, self.high
        u = min(max(float(u), 0.0), 1.0)
        if self.log:
            value = math.exp(math.log(lo) + u * (math.log(hi) - math.log(lo)))
        else:
            value = lo + u * (hi - lo)
        return float(min(max(value, lo), hi))

    def to_unit(self, value: float) -> float:
        """The unit coordinate of ``value`` (clipped into [0, 1])."""
        lo, hi = self.low, self.high
        if hi == lo:
            return 0.0
        if self.log:
            u = (math.log(value) - math.log(lo)) / (math.log(hi) - math.log(lo))
        else:
            u = (value - lo) / (hi - lo)
        return min(max(u, 0.0), 1.0)


@dataclass(frozen=True)
class KnobSpace:
    """Knobs searched together (:class:`~impactbench.tuning.search.UnitSpace`: the continuous
    knobs in unit coordinates, each log or linear; the categorical ones enumerated by
    :meth:`combos`). Absolute knobs only (:meth:`Knob.resolve` a relative one first)."""

    knobs: tuple[Knob, ...]

    def __post_init__(self) -> None:
        names = [k.name for k in self.knobs]
        if len(set(names)) != len(names):
            raise ValueError(f"knobs = {names}: each name once")
        for k in self.knobs:
            if k.relative:
                raise ValueError(f"knob {k.name}: relative to the scenario (per = {k.per!r}): "
                                 "resolve(scenario, dt) it first")
            if k.choices:
                continue
            if not (math.isfinite(k.low) and math.isfinite(k.high) and k.low <= k.high):
                raise ValueError(f"knob {k.name}: low = {k.low!r}, high = {k.high!r}: must be "
                                 "finite with low <= high")
            if k.log and k.low <= 0:
                raise ValueError(f"knob {k.name}: low = {k.low!r}: a log knob must be > 0")

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(k.name for k in self.knobs)

    @property
    def continuous(self) -> tuple[Knob, ...]:
        return tuple(k for k in self.knobs if not k.choices)

    @property
    def categorical(self) -> tuple[Knob, ...]:
        return tuple(k for k in self.knobs if k.choices)

    @property
    def start_candidate(self) -> dict[str, Any]:
        return {k.name: k.start for k in self.knobs}

    def to_unit(self, candidate: Mapping[str, Any]) -> np.ndarray:
        return np.array([k.to_unit(float(candidate[k.name])) for k in self.continuous])

    def from_unit(self, u: Sequence[float], fixed: Mapping[str, Any] | None = None
                  ) -> dict[str, Any]:
        """The candidate at unit coordinates ``u`` of the continuous knobs, the categorical
        ones from ``fixed`` (default their start); in the knobs' order. The start's own
        coordinates give the start's values exactly (not through exp(log))."""
        start = self.start_candidate
        u = np.asarray(u, dtype=float)
        at_start = np.array_equal(u, self.to_unit(start))
        out = {k.name: (fixed or {}).get(k.name, start[k.name]) for k in self.categorical}
        for k, ui in zip(self.continuous, u, strict=True):
            out[k.name] = start[k.name] if at_start else k.from_unit(ui)
        return {k.name: out[k.name] for k in self.knobs}

    def combos(self, first: Mapping[str, Any] | None = None) -> list[dict[str, Any]]:
        """Every combination of the categorical knobs, ``first``'s (default the start's)
        first."""
        cat = self.categorical
        combos = [dict(zip([k.name for k in cat], values, strict=True))
                  for values in itertools.product(*(k.choices for k in cat))]
        base = self.start_candidate if first is None else first
        head = {k.name: base[k.name] for k in cat}
        return [head] + [c for c in combos if c != head]


__all__ = ["PER", "Knob", "KnobSpace", "scenario_friction"]
