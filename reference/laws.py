"""Contact and structural force laws (SI units), each a small object.

Ball on plate (MODELS.md §1):
    :class:`HuntCrossley` — F(x, ẋ) = f(x)·(1 + b·ẋ) for x > 0, with f(x) = c·xⁿ or any
    increasing callable f with f(0) = 0.

Rigid–flexible 2-DOF (MODELS.md §2), local (contact) laws F1(Δx) ≥ 0, possibly with memory:
    :class:`LinearLocal`, :class:`Elastoplastic`, :class:`StiffnessMutation`;
structural laws F2(x2): :class:`LinearStructure`, :class:`SofteningStructure`.

The stepping contract of a local law, used by the event-driven solver and by engine adapters
in ``injected`` mode alike: ``force(dx)`` evaluates F1 at the current memory without changing
it; ``update(dx)`` commits an accepted state (advances the memory); ``reset()`` forgets it.
Adding a law means adding one class and one entry in :data:`LOCAL_LAWS` or
:data:`STRUCTURAL_LAWS`.
"""

from __future__ import annotations

import math
from abc import ABC, abstractmethod
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import ClassVar

from impactbench.reference import validation as check


@dataclass(frozen=True)
class HuntCrossley:
    """Hunt–Crossley contact F = f(x)·(1 + b·ẋ) for x > 0, else 0.

    Args:
        stiffness: c of the power law f = c·xⁿ (N/m^n). Ignored when ``elastic`` is given.
        exponent: n (3/2 for a Hertz sphere, 1 for a linear spring).
        damping: b (s/m); b = 0 is the elastic (Hertz) limit.
        elastic: optional increasing callable f(x) (N) with f(0) = 0, replacing c·xⁿ.
        potential: optional Π(x) = ∫₀ˣ f (J); computed by quadrature when omitted.
    """

    stiffness: float = 1.7135e10
    exponent: float = 1.5
    damping: float = 0.1
    elastic: Callable[[float], float] | None = field(default=None, compare=False)
    potential_fn: Callable[[float], float] | None = field(default=None, compare=False)

    def __post_init__(self) -> None:
        if self.elastic is None:
            check.positive("stiffness", self.stiffness)
            check.positive("exponent", self.exponent)
        elif not callable(self.elastic):
            raise ValueError(f"elastic = {self.elastic!r}: must be a callable f(x) in N")
        if self.potential_fn is not None and not callable(self.potential_fn):
            raise ValueError(f"potential_fn = {self.potential_fn!r}: must be a callable Π(x) in J")
        check.non_negative("damping", self.damping)

    @property
    def is_power_law(self) -> bool:
        return self.elastic is None

    def elastic_force(self, x: float) -> float:
        """f(x) in N (0 for x ≤ 0)."""
        if x <= 0.0:
            return 0.0
        if self.elastic is not None:
            return float(self.elastic(x))
        return self.stiffness * x**self.exponent

    def potential(self, x: float) -> float:
        """Π(x) = ∫₀ˣ f(s) ds in J (0 for x ≤ 0)."""
        if x <= 0.0:
            return 0.0
        if self.elastic is None:
            return self.stiffness * x ** (self.exponent + 1.0) / (self.exponent + 1.0)
        if self.potential_fn is not None:
            return float(self.potential_fn(x))
        from scipy import integrate  # here, not at import: the CLI's --help stays light

        return float(integrate.quad(self.elastic_force, 0.0, x, epsabs=0.0, epsrel=1e-13)[0])

    def force(self, x: float, rate: float) -> float:
        """Contact force F(x, ẋ) in N; never negative (1 + b·ẋ > 0 on every trajectory)."""
        if x <= 0.0:
            return 0.0
        return max(0.0, self.elastic_force(x) * (1.0 + self.damping * rate))


@dataclass(frozen=True)
class Boundary:
    """A switch of a piecewise-affine local law: g = cx·Δx + cv·Δẋ + c0 crossing zero.

    ``direction`` is +1 (g rising through 0) or −1 (falling); ``kind`` names the event
    (start, end, yield, turn, rejoin, fail); ``next_mode`` is the law's mode after it.
    """

    cx: float
    cv: float
    c0: float
    direction: int
    kind: str
    next_mode: str

    def value(self, dx: float, rate: float) -> float:
        return self.cx * dx + self.cv * rate + self.c0


@dataclass(frozen=True)
class Piece:
    """One smooth piece of a local law: F1 = stiffness·Δx + offset (N), valid until a boundary.

    ``stiffness`` is 0 (and offset 0) in the free (no contact) mode.
    """

    mode: str
    stiffness: float
    offset: float
    boundaries: tuple[Boundary, ...]

    @property
    def contact(self) -> bool:
        return self.stiffness > 0.0

    def force(self, dx: float) -> float:
        return self.stiffness * dx + self.offset if self.stiffness > 0.0 else 0.0


def _rising_dx(at: float, kind: str, next_mode: str) -> Boundary:
    return Boundary(1.0, 0.0, -at, +1, kind, next_mode)


def _falling_dx(at: float, kind: str, next_mode: str) -> Boundary:
    return Boundary(1.0, 0.0, -at, -1, kind, next_mode)


def _turn(next_mode: str, kind: str = "turn") -> Boundary:
    return Boundary(0.0, 1.0, 0.0, -1, kind, next_mode)


class LocalLaw(ABC):
    """Local (contact) law F1(Δx) ≥ 0 of the 2-DOF model, with optional memory.

    Besides the stepping contract (``force``/``update``/``reset``) every built-in law is
    piecewise affine in Δx, which the event-driven solver uses: ``piece(mode)`` returns the
    current :class:`Piece` and its :class:`Boundary` switches; on an event the solver calls
    ``commit(kind, dx)`` (memory) and continues in ``boundary.next_mode``. Every law starts
    in mode ``"free"``; the first contact starts with that mode's ``start`` boundary.
    """

    name: ClassVar[str]

    def piece(self, mode: str) -> Piece:
        """The smooth piece of F1 in ``mode`` with the current memory."""
        raise NotImplementedError(f"{type(self).__name__} does not describe its pieces")

    def commit(self, kind: str, dx: float) -> None:
        """Advance the memory at an event of ``kind`` reached at penetration Δx (m)."""
        self.update(dx)

    def contact_threshold(self) -> float:
        """Δx (m) where contact starts and ends with the current memory (the permanent set)."""
        return 0.0

    def stored_energy(self, dx: float) -> float:
        """Elastic energy (J) the contact would return on unloading from Δx (m)."""
        f = self.force(dx)
        return 0.0 if f <= 0.0 else 0.5 * f * max(dx - self.contact_threshold(), 0.0)

    def reset(self) -> None:  # noqa: B027 - stateless laws have nothing to forget
        """Forget the loading history."""

    @abstractmethod
    def force(self, dx: float) -> float:
        """F1 (N) at penetration Δx (m) with the current memory; does not change it."""

    def update(self, dx: float) -> None:  # noqa: B027 - stateless laws keep no memory
        """Commit the accepted penetration Δx (m): advance the memory."""


@dataclass
class LinearLocal(LocalLaw):
    """F1 = k1·Δx for Δx > 0, else 0."""

    k1: float
    name: ClassVar[str] = "linear"

    def force(self, dx: float) -> float:
        return self.k1 * dx if dx > 0.0 else 0.0

    def piece(self, mode: str) -> Piece:
        if mode == "free":
            return Piece(mode, 0.0, 0.0, (_rising_dx(0.0, "start", "contact"),))
        return Piece(mode, self.k1, 0.0, (_falling_dx(0.0, "end", "free"),))


@dataclass
class Elastoplastic(LocalLaw):
    """Bilinear elastoplastic contact with memory.

    Backbone: k1·Δx up to εs, then k1·εs + kt·(Δx − εs). Unloading from the largest
    penetration reached, Δx_m (force F_m on the backbone), is elastic:
    F1 = max(0, F_m − k1·(Δx_m − Δx)); reloading retraces that line, then the backbone.
    The permanent set is Δx_m − F_m/k1.
    """

    k1: float
    kt: float
    eps_s: float
    max_dx: float = 0.0
    name: ClassVar[str] = "elastoplastic"

    def backbone(self, dx: float) -> float:
        if dx <= self.eps_s:
            return self.k1 * dx
        return self.k1 * self.eps_s + self.kt * (dx - self.eps_s)

    @property
    def permanent_set(self) -> float:
        """Δx_m − F_m/k1 (m): where contact starts and ends after yielding."""
        return self.max_dx - self.backbone(self.max_dx) / self.k1

    def reset(self) -> None:
        self.max_dx = 0.0

    def force(self, dx: float) -> float:
        if dx <= 0.0:
            return 0.0
        if dx >= self.max_dx:
            return self.backbone(dx)
        return max(0.0, self.backbone(self.max_dx) - self.k1 * (self.max_dx - dx))

    def update(self, dx: float) -> None:
        self.max_dx = max(self.max_dx, dx)

    def contact_threshold(self) -> float:
        return 0.0 if self.max_dx <= self.eps_s else self.permanent_set

    def stored_energy(self, dx: float) -> float:
        f = self.force(dx)
        return 0.5 * f * f / self.k1

    def piece(self, mode: str) -> Piece:
        """Modes: free, line (elastic unload/reload line), elastic (backbone ≤ εs), plastic."""
        p, dm = self.contact_threshold(), self.max_dx
        backbone_mode = "elastic" if dm < self.eps_s else "plastic"
        if mode == "free":
            return Piece(mode, 0.0, 0.0,
                         (_rising_dx(p, "start", "line" if dm > 0.0 else "elastic"),))
        if mode == "line":
            return Piece(mode, self.k1, -self.k1 * p,
                         (_falling_dx(p, "end", "free"), _rising_dx(dm, "rejoin", backbone_mode)))
        if mode == "elastic":
            return Piece(mode, self.k1, 0.0,
                         (_rising_dx(self.eps_s, "yield", "plastic"), _turn("line")))
        return Piece(mode, self.kt, (self.k1 - self.kt) * self.eps_s, (_turn("line"),))


@dataclass
class StiffnessMutation(LocalLaw):
    """One-off local failure: F1 = k1·Δx until the force first reaches F_m, then k1'·Δx.

    The paper's eq. 5 is illegible in our copy; this irreversible stiffness drop is the
    reading impactbench uses (MODELS.md §2). Swap the class to try another reading.
    """

    k1: float
    k1_failed: float
    fm: float
    failed: bool = False
    name: ClassVar[str] = "mutation"

    def reset(self) -> None:
        self.failed = False

    def force(self, dx: float) -> float:
        if dx <= 0.0:
            return 0.0
        if self.failed or self.k1 * dx >= self.fm:
            return self.k1_failed * dx
        return self.k1 * dx

    def update(self, dx: float) -> None:
        if self.k1 * dx >= self.fm:
            self.failed = True

    def commit(self, kind: str, dx: float) -> None:
        if kind == "fail":
            self.failed = True
        else:
            self.update(dx)

    def piece(self, mode: str) -> Piece:
        """Modes: free, intact (k1), failed (k1')."""
        if mode == "free":
            return Piece(mode, 0.0, 0.0,
                         (_rising_dx(0.0, "start", "failed" if self.failed else "intact"),))
        if mode == "intact":
            return Piece(mode, self.k1, 0.0, (_falling_dx(0.0, "end", "free"),
                                              _rising_dx(self.fm / self.k1, "fail", "failed")))
        return Piece(mode, self.k1_failed, 0.0, (_falling_dx(0.0, "end", "free"),))


@dataclass
class ContinuousMutation(Elastoplastic):
    """A reading of the paper's illegible eq. 5 with the force continuous at failure.

    F1 = k1·Δx until it reaches F_m, then F_m + k1'·(Δx − F_m/k1); unloading and reloading
    from the largest penetration Δx_m with slope k1, as eq. 4 unloads the elastoplastic law.
    It is :class:`Elastoplastic` with εs = F_m/k1 and kt = k1' (``kt`` holds k1'). Selectable
    as local law ``mutation-continuous``; not one of the paper's three laws
    (:data:`LOCAL_LAW_READINGS`).
    """

    name: ClassVar[str] = "mutation-continuous"

    @classmethod
    def from_failure(cls, k1: float, k1_failed: float, fm: float) -> ContinuousMutation:
        """From k1 (N/m), k1' (N/m) and the failure force F_m (N)."""
        return cls(k1, k1_failed, fm / k1)


class StructuralLaw(ABC):
    """Structural law F2(x2) tying body 2 to the ground (stateless)."""

    name: ClassVar[str]

    @abstractmethod
    def force(self, x2: float) -> float:
        """Restoring force F2 (N) at displacement x2 (m)."""

    @abstractmethod
    def potential(self, x2: float) -> float:
        """Stored energy (J) at displacement x2 (m)."""

    @property
    def collapse_energy(self) -> float:
        """Energy (J) above which the structure runs away; inf if it never does."""
        return math.inf

    @property
    def collapse_displacement(self) -> float:
        """x2 (m) of the potential's peak, beyond which F2 pushes outward; inf if none."""
        return math.inf

    @abstractmethod
    def max_force(self, reach_m: float) -> float:
        """Largest F2 (N) over 0 ≤ x2 ≤ reach_m (m). Out of contact the gap's acceleration
        is F2/m2, so this bounds how fast a free gap can close (the free-flight step)."""

    @abstractmethod
    def reach(self, energy_j: float) -> float:
        """Largest |x2| (m) body 2 can reach with this mechanical energy (inf on collapse)."""


@dataclass(frozen=True)
class LinearStructure(StructuralLaw):
    """F2 = k2·x2."""

    k2: float
    name: ClassVar[str] = "linear"

    def force(self, x2: float) -> float:
        return self.k2 * x2

    def potential(self, x2: float) -> float:
        return 0.5 * self.k2 * x2 * x2

    def max_force(self, reach_m: float) -> float:
        return self.k2 * reach_m

    def reach(self, energy_j: float) -> float:
        return math.sqrt(2.0 * max(energy_j, 0.0) / self.k2)


@dataclass(frozen=True)
class SofteningStructure(StructuralLaw):
    """Cubic softening F2 = k2·x2 − β·x2³; its potential peaks at k2²/(4β) at x2 = ±√(k2/β)."""

    k2: float
    beta: float
    name: ClassVar[str] = "softening"

    def force(self, x2: float) -> float:
        return self.k2 * x2 - self.beta * x2**3

    def potential(self, x2: float) -> float:
        return 0.5 * self.k2 * x2**2 - 0.25 * self.beta * x2**4

    @property
    def collapse_energy(self) -> float:
        return self.k2**2 / (4.0 * self.beta) if self.beta > 0.0 else math.inf

    def reach(self, energy_j: float) -> float:
        """Root of ½k2x² − ¼βx⁴ = E inside the well: x² = (k2 − √(k2² − 4βE))/β."""
        e = max(energy_j, 0.0)
        if self.beta == 0.0:
            return math.sqrt(2.0 * e / self.k2)
        disc = self.k2**2 - 4.0 * self.beta * e
        if disc <= 0.0:
            return math.inf
        # k2 − √disc written without cancellation: 4βE / (k2 + √disc)
        return math.sqrt(4.0 * e / (self.k2 + math.sqrt(disc)))

    @property
    def collapse_displacement(self) -> float:
        """|x2| (m) at the potential's peak, beyond which the force pushes outward."""
        return math.sqrt(self.k2 / self.beta) if self.beta > 0.0 else math.inf

    def max_force(self, reach_m: float) -> float:
        """F2 rises up to x2 = √(k2/(3β)) (its peak, (2/3)·k2·√(k2/(3β))), then falls."""
        x = reach_m if self.beta == 0.0 else min(reach_m, math.sqrt(self.k2 / (3.0 * self.beta)))
        return self.force(x) if math.isfinite(x) else math.inf


def no_further_contact(x1: float, v1: float, x2: float, v2: float, m2: float,
                       structure: StructuralLaw) -> bool:
    """True when body 1 can never touch body 2 again (positions from first touch, m; m/s).

    Valid out of contact (Δx below the contact threshold), where body 1 moves freely at
    constant v1 and body 2 is a conservative oscillator. Two rules, either suffices:

    1. *Bounded* (body 2 in its well): body 2's mechanical energy E2 = ½·m2·v2² + Π(x2) bounds
       its reach |x2| ≤ reach(E2). Contact needs x1 − x2 > 0 (after yielding, more), so once
       v1 ≤ 0 and x1 < −reach(E2) no further contact is possible.
    2. *Escaped* (a collapsed softening structure, :func:`escaped`): body 2 is past the
       potential's peak, x2 > x_c = √(k2/β), and moves away at least as fast as body 1,
       v2 ≥ max(v1, 0).

    ``x1`` is body 1's position minus the local law's contact threshold (the permanent set).
    """
    if escaped(v1, x2, v2, structure):
        return True
    reach = structure.reach(0.5 * m2 * v2 * v2 + structure.potential(x2))
    return v1 <= 0.0 and x1 < -reach


def escaped(v1: float, x2: float, v2: float, structure: StructuralLaw) -> bool:
    """True when a collapsed body 2 has escaped body 1 for good (m, m/s; out of contact).

    Derivation: past the potential's peak, x2 > x_c, the structural force pushes outward,
    F2(x2) < 0, so out of contact ẍ2 = −F2/m2 > 0 — once v2 ≥ 0 it stays so, x2 only grows
    and stays past x_c (a contact would push body 2 outward too). Body 1 moves freely
    (ẍ1 = 0), so the gap rate Δẋ = v1 − v2 falls strictly: d(Δẋ)/dt = F2/m2 < 0. From
    v1 ≤ v2, Δx only decreases and never returns to the contact threshold. (Body 2 reaches
    infinity in finite time; this rule ends the run before.) Laws that never soften
    (x_c = ∞) never escape.
    """
    xc = structure.collapse_displacement
    return x2 > xc and v2 >= max(v1, 0.0)


LOCAL_LAWS: dict[str, type[LocalLaw]] = {
    cls.name: cls for cls in (LinearLocal, Elastoplastic, StiffnessMutation)
}
LOCAL_LAW_READINGS: dict[str, type[LocalLaw]] = {ContinuousMutation.name: ContinuousMutation}
"""Other readings of the paper's local laws, selectable by name but not swept by default."""
ALL_LOCAL_LAWS: dict[str, type[LocalLaw]] = {**LOCAL_LAWS, **LOCAL_LAW_READINGS}
STRUCTURAL_LAWS: dict[str, type[StructuralLaw]] = {
    cls.name: cls for cls in (LinearStructure, SofteningStructure)
}
