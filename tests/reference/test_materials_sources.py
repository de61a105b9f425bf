"""Each number of the materials table against its cited source, in the source's own unit.

``test_materials.py`` only range-checks the table (E > 0, ν in (−1, 0.5) …): a modulus
entered in the wrong unit or copied from the wrong row would pass it. Here every value the
header attributes to [callister] is written out as Callister prints it (GPa, g/cm³) and
converted to the table's SI units; the rubber row is held to the range its own description
states ([gent] gives a range by compound, not one value); the nominal restitutions to the
ranges and the one measured value the repository carries (Kharaz et al. 2001's alumina).
"""

from __future__ import annotations

import math
import re
import tomllib
from importlib import resources

import pytest
from impactbench.reference import materials as mat

GPA = 1e9  # Pa per GPa
G_PER_CM3 = 1000.0  # kg/m³ per g/cm³

# W. D. Callister, D. G. Rethwisch, Materials Science and Engineering: An Introduction,
# 9th ed., Wiley, 2014, Appendix B — Table B.1 density (g/cm³), Table B.2 modulus of
# elasticity (GPa), Table B.3 Poisson's ratio; the rows named in each entry's description.
CALLISTER = {
    # material: (row of Appendix B, E in GPa [B.2], ν [B.3], ρ in g/cm³ [B.1])
    "steel": ("Steel alloy 1020 (plain carbon)", 207.0, 0.30, 7.85),
    "aluminium": ("Aluminum alloy 6061", 69.0, 0.33, 2.70),
    "glass": ("Glass, soda-lime", 69.0, 0.23, 2.5),
    "alumina": ("Aluminum oxide, 99.9% pure", 380.0, 0.22, 3.98),
    "brass": ("Brass, cartridge (C26000)", 110.0, 0.35, 8.53),
}
# A. N. Gent (ed.), Engineering with Rubber, 3rd ed., Hanser, 2012, ch. 1: soft vulcanised
# natural rubber has E of 1–10 MPa by compound (the range the table's description quotes)
# and is nearly incompressible (ν → 0.5; the table takes 0.49); gum and lightly filled
# natural rubber weigh 0.93–1.2 g/cm³.
RUBBER_E_MPA = (1.0, 10.0)
RUBBER_DENSITY_G_CM3 = (0.93, 1.2)
# Kharaz, Gorham & Salman, Powder Technol. 120(3):281–291, 2001 — as reference/data/
# kharaz2001/README.md records it: alumina spheres on a glass anvil at 3.9 m/s, normal
# coefficient of restitution 0.98.
KHARAZ_ALUMINA_NORMAL_RESTITUTION = 0.98


def raw_table() -> tuple[str, dict]:
    text = resources.files("impactbench.reference").joinpath("data/materials.toml").read_text()
    return text, tomllib.loads(text)


@pytest.mark.parametrize("name", sorted(CALLISTER))
def test_callister_rows_in_si(name: str) -> None:
    row, e_gpa, nu, rho_g_cm3 = CALLISTER[name]
    m = mat.material(name)
    assert m.source == "callister"
    assert m.youngs_modulus_pa == pytest.approx(e_gpa * GPA, rel=1e-12), row
    assert m.poisson == pytest.approx(nu, abs=1e-12), row
    assert m.density_kg_m3 == pytest.approx(rho_g_cm3 * G_PER_CM3, rel=1e-12), row


def test_rubber_within_its_sources_ranges() -> None:
    m = mat.material("rubber")
    assert m.source == "gent"
    assert RUBBER_E_MPA[0] * 1e6 <= m.youngs_modulus_pa <= RUBBER_E_MPA[1] * 1e6
    assert "1-10 MPa" in m.description
    assert 0.49 <= m.poisson < 0.5
    lo, hi = RUBBER_DENSITY_G_CM3
    assert lo * G_PER_CM3 <= m.density_kg_m3 <= hi * G_PER_CM3


def test_every_source_key_is_in_the_header_and_every_row_is_covered() -> None:
    text, table = raw_table()
    header = {k for k in re.findall(r"^#\s+\[(\w+)\]", text, flags=re.M)}
    assert header == {"callister", "goldsmith", "kharaz", "gent", "cross"}
    for name, row in table.items():
        assert row["source"] in header and row["restitution_source"] in header, name
    assert set(table) == set(CALLISTER) | {"rubber"}  # a new row needs its source here


def test_nominal_restitution_inside_its_range_and_kharaz_value() -> None:
    for m in mat.materials().values():
        lo, hi = m.restitution_range
        assert 0.0 < lo <= m.restitution <= hi <= 1.0, m.name
    alumina = mat.material("alumina")
    assert alumina.restitution_source == "kharaz"
    lo, hi = alumina.restitution_range
    assert lo <= KHARAZ_ALUMINA_NORMAL_RESTITUTION <= hi


def test_steel_ball_mass_and_stiffness_from_the_callister_row() -> None:
    """The numbers reach the ball: m = ρ·4/3·πR³ and Hertz c = (4/3)E*√R with
    1/E* = 2(1 − ν²)/E for steel on steel (Johnson, Contact Mechanics, 1985, §4.2)."""
    _, e_gpa, nu, rho = CALLISTER["steel"]
    r = 0.01
    p = mat.ball_parameters(r, material_name="steel")
    assert p["mass_kg"] == pytest.approx(rho * G_PER_CM3 * 4.0 / 3.0 * math.pi * r**3,
                                         rel=1e-13)
    e_star = e_gpa * GPA / (2.0 * (1.0 - nu**2))
    assert p["stiffness"] == pytest.approx(4.0 / 3.0 * e_star * math.sqrt(r), rel=1e-13)
