"""Local and structural laws of the 2-DOF model: the stepping contract, the piece machine the
event-driven solver uses, and the structural energy bounds."""

from __future__ import annotations

import math

import numpy as np
import pytest
from impactbench.reference.laws import (
    Elastoplastic,
    LinearLocal,
    LinearStructure,
    SofteningStructure,
    StiffnessMutation,
    no_further_contact,
)

LAWS = [LinearLocal(1e5), Elastoplastic(1e5, 2e4, 0.07), StiffnessMutation(1e5, 5e4, 1e3)]


def path() -> np.ndarray:
    """Load past yield/failure, unload to a gap, reload past the old maximum, unload."""
    legs = [(0.0, 0.1), (0.1, -0.01), (-0.01, 0.12), (0.12, -0.02)]
    return np.concatenate([np.linspace(a, b, 4001)[1:] for a, b in legs])


def walk_pieces(law, dxs: np.ndarray) -> list[float]:
    """F1 along ``dxs`` from the piece machine alone (boundaries crossed → next mode)."""
    law.reset()
    mode, out, prev_dx, prev_rate = "free", [], -1e-12, 1e-12
    for dx in dxs:
        rate = dx - prev_dx
        for _ in range(4):
            piece = law.piece(mode)
            for b in piece.boundaries:
                g0, g1 = b.value(prev_dx, prev_rate), b.value(dx, rate)
                if (b.direction > 0 and g0 < 0 <= g1) or (b.direction < 0 and g0 > 0 >= g1):
                    at = prev_dx if b.kind == "turn" else -(b.c0 + b.cv * rate) / b.cx
                    law.commit(b.kind, at)
                    mode = b.next_mode
                    break
            else:
                break
        out.append(law.piece(mode).force(dx))
        prev_dx, prev_rate = dx, rate
    return out


def walk_contract(law, dxs: np.ndarray) -> list[float]:
    law.reset()
    out = []
    for dx in dxs:
        out.append(law.force(dx))
        law.update(dx)
    return out


@pytest.mark.parametrize("law", LAWS, ids=lambda law: law.name)
def test_pieces_reproduce_the_stepping_contract(law):
    dxs = path()
    a, b = np.array(walk_pieces(law, dxs)), np.array(walk_contract(law, dxs))
    assert np.max(np.abs(a - b)) <= 1e-9 * np.max(b)


def test_elastoplastic_memory_and_permanent_set():
    law = Elastoplastic(1e5, 2e4, 0.07)
    for dx in np.linspace(0, 0.1, 11):
        law.update(dx)
    fm = 1e5 * 0.07 + 2e4 * 0.03
    assert law.force(0.1) == pytest.approx(fm)
    assert law.contact_threshold() == pytest.approx(0.1 - fm / 1e5)
    assert law.force(law.contact_threshold() - 1e-9) == 0.0
    assert law.force(0.09) == pytest.approx(fm - 1e5 * 0.01)  # on the elastic line
    assert law.stored_energy(0.1) == pytest.approx(fm**2 / 2e5)
    law.reset()
    assert law.contact_threshold() == 0.0 and law.force(0.05) == pytest.approx(5e3)


def test_mutation_is_irreversible():
    law = StiffnessMutation(1e5, 5e4, 1e3)
    assert law.force(0.009) == pytest.approx(900.0)
    law.update(0.011)
    assert law.failed and law.force(0.009) == pytest.approx(450.0)
    law.update(0.0)
    assert law.force(0.009) == pytest.approx(450.0)


def test_softening_reach_inverts_the_potential_and_collapse_energy():
    s = SofteningStructure(1e5, 3e6)
    assert s.collapse_energy == pytest.approx(1e10 / 1.2e7)
    assert s.potential(s.collapse_displacement) == pytest.approx(s.collapse_energy)
    for e in (1e-3, 10.0, 500.0, 0.999 * s.collapse_energy):
        assert s.potential(s.reach(e)) == pytest.approx(e, rel=1e-12)
    assert math.isinf(s.reach(1.001 * s.collapse_energy))
    lin = LinearStructure(1e5)
    assert lin.potential(lin.reach(7.0)) == pytest.approx(7.0)


def test_no_further_contact_needs_distance_and_retreat():
    s = LinearStructure(1e5)
    reach = s.reach(0.5 * 10 * 1.0**2)  # body 2 at rest position moving at 1 m/s
    assert no_further_contact(-1.01 * reach, -0.1, 0.0, 1.0, 10.0, s)
    assert not no_further_contact(-0.99 * reach, -0.1, 0.0, 1.0, 10.0, s)
    assert not no_further_contact(-1.01 * reach, 0.1, 0.0, 1.0, 10.0, s)
