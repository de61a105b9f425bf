"""Shared by the pasted-snippet tests (``test_paste_<engine>.py``): read a plain script's head-on
ball the way the suite reads a record, and hold the advice's claims against it.

A plain script is the engine's own API and nothing of impactbench's: the paper's ball over a
static plate, no gravity, no friction, the engine's defaults plus what the advice's snippet
says, the ball started (2 + φ)·V·dt above the plate at −V (V in m/s, dt the snippet's step in
s). It steps until the contact is over and keeps the ball's velocity along the plate's outward
normal at the start of every step (``vel[k]``, m/s; ``vel[n]`` after the last) and whether a
contact force acted over step k (``pushed[k]``).

Reading it as the suite does (:func:`impactbench.reference.metrics.compute`): e = rebound speed
over impact speed, each read at the free-flight sample just outside a contact of fewer than 10
force samples (``MIN_CONTACT_SAMPLES``), or, for a longer contact, interpolated at its located
edges, each between a sample in contact and one in free flight, so e then lies between the
readings at those samples (at MuJoCo's customary 2 ms its default ``solref="0.02 1"`` contact
spans ~44 steps, and the readings differ by up to 5e-4 in e).

The snippet prints every number with 10 significant digits (``advice_models._g``) while the
advice ran the unrounded values: the test reruns the plain script with each number printed
with all 10 digits (a searched value; a shorter one is as set) moved by half a unit in its
10th digit, either way, and widens the reading by the largest move each number makes (first
order). Measured at MuJoCo's 2 ms when the snippet printed 6 digits: the rounding of a direct
``solref="-246026 -8.72031"`` moved e by 1.8e-6, of ``"-87230.4 -5.3827"`` by 1.7e-7; a 6-digit
PyBullet restitution printed 0.84767 (a trailing zero dropped, so taken as exact) for
0.8476701389 and the plain e was 1.4e-7 off — hence 10 digits. With 10 the rounding moves e
by at most 1.8e-10 (MuJoCo's packaged ``solref="-220546.2776 -57.55881061"``) and 3.7e-11
(PyBullet's ``restitution=0.8476701389``).
"""

from __future__ import annotations

import math
import re
import statistics
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

MIN_CONTACT_SAMPLES = 10
"""A contact with fewer force samples is read at the free-flight samples just outside it."""
ENERGY_GAIN_LIMIT = 0.01
"""The suite's divergence rule: a run ending with over 1 % more kinetic energy than it started
with is ``diverged``, and a diverged phase is left out of the advice's min/median/max."""
SIGNIFICANT_DIGITS = 10
NUMBER = r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?"
"""A number in a snippet (a regular expression)."""


def half_unit(x: float) -> float:
    """Half a unit in the last of the snippet's 10 significant digits of ``x`` (0 for 0)."""
    if x == 0.0:
        return 0.0
    return 0.5 * 10.0 ** (math.floor(math.log10(abs(x))) - (SIGNIFICANT_DIGITS - 1))


def digits(token: str) -> int:
    """Significant digits of a printed number (``"-8.72031"``: 6, ``"0.002"``: 1)."""
    mantissa = re.split(r"[eE]", token.lstrip("+-"))[0].replace(".", "").lstrip("0")
    return len(mantissa)


def nudged(text: str, value: str = NUMBER) -> list[str]:
    """``text`` with each of its numbers that are settings (the regular expression ``value``,
    whose group ``n`` is the number; default: every number) and may have been rounded (printed
    with all 10 significant digits: a shorter one, such as the step 0.002 or a fixed 0.0001, is
    the advice's own value) moved by +/- half a unit of its last printed digit, one number and
    one side at a time (2 per number, in order)."""
    out = []
    for m in re.finditer(value if "(?P<n>" in value else f"(?P<n>{value})", text):
        if digits(m.group("n")) < SIGNIFICANT_DIGITS:
            continue
        x = float(m.group("n"))
        a, b = m.span("n")
        for side in (1.0, -1.0):
            out.append(text[:a] + repr(x + side * half_unit(x)) + text[b:])
    return out


@dataclass(frozen=True)
class Run:
    """One plain run: ``vel`` (m/s, n + 1 samples along the outward normal), ``pushed`` (n
    steps), ``diverged`` (the engine reported a blow-up, or the ball ended with over 1 % more
    kinetic energy than at launch) and ``ended`` (the contact was over before the cap)."""

    vel: Sequence[float]
    pushed: Sequence[bool]
    launch_speed: float
    diverged: bool = False
    ended: bool = True

    @property
    def excluded(self) -> bool:
        """Left out of the advice's spread: diverged, or still in contact at the cap."""
        gain = (self.vel[-1] / self.launch_speed) ** 2 - 1.0
        return self.diverged or not self.ended or not gain <= ENERGY_GAIN_LIMIT

    def contacts(self) -> list[tuple[int, int]]:
        """Runs of consecutive steps with force, (first, last) step of each."""
        out: list[tuple[int, int]] = []
        for k, on in enumerate(self.pushed):
            if on and out and out[-1][1] == k - 1:
                out[-1] = (out[-1][0], k)
            elif on:
                out.append((k, k))
        return out

    def restitution(self) -> tuple[float, float]:
        """(lowest, highest) e the suite can read from this run (module doc)."""
        cs = self.contacts()
        assert cs, "the ball never touched the plate"
        (i, j0), (i1, j) = cs[0], cs[-1]
        v_in = [self.vel[i - 1]] if j0 - i + 1 < MIN_CONTACT_SAMPLES else \
            [self.vel[i - 1], self.vel[i]]
        v_out = [self.vel[j + 1]] if j - i1 + 1 < MIN_CONTACT_SAMPLES else \
            [self.vel[j], self.vel[j + 1]]
        speeds_in = [abs(v) for v in v_in]
        return min(v_out) / max(speeds_in), max(v_out) / min(speeds_in)

    def free_flight_restitution(self) -> float:
        """e read at the free-flight samples just outside the contact, whatever its length."""
        cs = self.contacts()
        return self.vel[cs[-1][1] + 1] / abs(self.vel[cs[0][0] - 1])


@dataclass(frozen=True)
class Reading:
    """One speed and phase of the plain script: e's range (the reading at the snippet's
    numbers, widened by the reading's own range and the numbers' rounding) and whether the
    suite would leave the phase out."""

    low: float
    high: float
    excluded: bool
    free_flight: float
    """e at the printed numbers, read at the free-flight samples around the contact."""
    launch: float
    """e at the printed numbers, the speed at the end of the run over the launch speed."""


def reading(runs: Sequence[Run]) -> Reading:
    """The plain reading of one speed and phase from its runs: ``runs[0]`` at the printed
    numbers, the others each with one number nudged (:func:`nudged`), in pairs."""
    lo0, hi0 = runs[0].restitution()
    mid = 0.5 * (lo0 + hi0)
    spread = 0.0
    for a, b in zip(runs[1::2], runs[2::2], strict=True):
        moves = [abs(0.5 * sum(r.restitution()) - mid) for r in (a, b) if not r.excluded]
        spread += max(moves, default=0.0)
    return Reading(lo0 - spread, hi0 + spread, runs[0].excluded,
                   runs[0].free_flight_restitution(), runs[0].vel[-1] / runs[0].launch_speed)


def distance(x: float, low: float, high: float) -> float:
    """How far ``x`` lies outside [low, high] (0 inside)."""
    return max(low - x, x - high, 0.0)


def discrepancies(per_speed: Iterable[Mapping], phases: Sequence[float],
                  readings: Mapping[tuple[float, float], Reading]) -> dict[float, dict]:
    """Per speed (m/s): how far each of the advice's claims lies outside what the plain script
    allows — ``phase`` (worst over the kept phases: the phase's range against the claimed
    [min, max]), ``min``, ``max``, ``median`` (the claim against the plain range of that
    statistic over the kept phases), and for the record ``free_flight`` and ``launch`` (the
    largest |claimed − plain| of min, median and max with the plain e read at the printed
    numbers without allowances: :attr:`Reading.free_flight`, :attr:`Reading.launch`) — and
    ``excluded`` (phases left out) with the speed's ``status``."""
    out = {}
    for row in per_speed:
        v = float(row["velocity_m_s"])
        got = [readings[v, ph] for ph in phases]
        kept = [r for r in got if not r.excluded]
        lo_c, hi_c = float(row["restitution_min"]), float(row["restitution_max"])
        d: dict = {"status": row["status"], "excluded": len(got) - len(kept)}
        if kept:
            lows, highs = [r.low for r in kept], [r.high for r in kept]
            d["phase"] = max(max(lo_c - r.high, r.low - hi_c, 0.0) for r in kept)
            d["min"] = distance(lo_c, min(lows), min(highs))
            d["max"] = distance(hi_c, max(lows), max(highs))
            d["median"] = distance(float(row["restitution"]), statistics.median(lows),
                                   statistics.median(highs))
            for name in ("free_flight", "launch"):
                es = [getattr(r, name) for r in kept]
                d[name] = max(abs(min(es) - lo_c), abs(max(es) - hi_c),
                              abs(statistics.median(es) - float(row["restitution"])))
        out[v] = d
    return out


def assert_matches(per_speed: Sequence[Mapping], phases: Sequence[float],
                   readings: Mapping[tuple[float, float], Reading], tol: float) -> None:
    """The advice's claims hold for the plain script within ``tol`` (in e): each kept phase's
    e within [min − tol, max + tol], the min, median and max over the kept phases the claimed
    ones; a phase the suite leaves out (diverged: energy gained) exactly where the speed's
    status says ``diverged``, and none of them all."""
    for v, d in discrepancies(per_speed, phases, readings).items():
        assert d["excluded"] < len(phases), (v, d)
        assert (d["excluded"] > 0) == (d["status"] in ("diverged", "max_time")), (v, d)
        for key in ("phase", "min", "max", "median"):
            assert d[key] <= tol, (v, key, d)


def read_all(run: Callable[[str, float, float], Run], text: str, speeds: Sequence[float],
             phases: Sequence[float], value: str = NUMBER
             ) -> dict[tuple[float, float], Reading]:
    """Each speed and phase's :class:`Reading` of the plain script ``run(text, V, phase)``
    built from the snippet ``text`` as printed and from each nudged copy (``value``: which
    numbers are settings, :func:`nudged`)."""
    texts = [text, *nudged(text, value)]
    return {(v, ph): reading([run(t, v, ph) for t in texts]) for v in speeds for ph in phases}


MJCF = """<mujoco model="plain ball on plate">
  <option {option}/>
  <default><geom {geom}/></default>
  <worldbody>
    <geom name="plate" type="plane" size="1 1 0.1"/>
    <body name="ball" pos="0 0 {radius!r}">
      <joint name="height" type="slide" axis="0 0 1"/>
      <geom name="ball" type="sphere" size="{radius!r}" mass="{mass!r}"/>
    </body>
  </worldbody>
</mujoco>"""
"""A user's plain MJCF: a plane and a sphere on a vertical slide joint whose coordinate is
the height of its lowest point above the plane (m)."""


def _attributes(text: str, element: str) -> dict[str, str]:
    found = re.search(element, text)
    return dict(re.findall(r'(\w+)="([^"]*)"', found.group(1))) if found else {}


def mjcf(text: str, radius_m: float, mass_kg: float) -> str:
    """The plain MJCF of a MuJoCo (or MJX) snippet ``text``: its ``<option>`` and its default
    ``<geom>`` attributes as printed (regexes on the text), with no gravity and MuJoCo's
    frictionless contact (``condim="1"``, friction 0) added; MuJoCo's defaults otherwise."""
    option = {"gravity": "0 0 0", **_attributes(text, r"<option\s([^>]*?)/>")}
    geom = {"condim": "1", "friction": "0 0 0",
            **_attributes(text, r"<default>\s*<geom\s([^>]*?)/>\s*</default>")}
    assert "timestep" in option and "solref" in geom, text

    def joined(d: dict[str, str]) -> str:
        return " ".join(f'{k}="{v}"' for k, v in d.items())

    return MJCF.format(option=joined(option), geom=joined(geom), radius=radius_m, mass=mass_kg)


def measured(runs: Sequence[Any]) -> list[Any]:
    """The phases' readings the suite measures: e finite and no more than
    :data:`ENERGY_GAIN_LIMIT` kinetic energy gained (a reading is e, or (e, slack))."""
    def e_of(r: Any) -> float:
        return float(r[0] if isinstance(r, tuple) else r)

    return [r for r in runs if math.isfinite(e_of(r))
            and e_of(r) ** 2 <= 1.0 + ENERGY_GAIN_LIMIT]
