"""The rigid theory's RMS errors against Kharaz, Gorham & Salman (2001), recomputed without the
package: the data read from its CSV with the csv module, the normal restitution from the
Hunt–Crossley energy integral (scipy root), the tangential outcome from the rigid Coulomb
impulse written out with numpy. The pinned rows (``RMS`` of test_oblique_microslip.py and the
numbers of test_oblique.py's Kharaz tests) were measured with the package's own path
(:func:`impactbench.reference.oblique.rigid` on :meth:`Oblique.kharaz2001`); this is the second
computation.

The rigid theory (a sphere, k² = 2R²/5, no initial spin; e.g. Maw, Barber & Fawcett, Wear
36:199, 1976, the rigid limit; Brach 1991): with v_n = V·cos θ, v_t = V·sin θ and the Coulomb
impulse per unit mass P = μ·(1 + e)·v_n, the sphere slides throughout when v_t > (1 + R²/k²)·P
= 3.5·P: v_t' = v_t − P, ω' = (R/k²)·P = 2.5·P/R; otherwise it leaves rolling:
v_t' = (5/7)·v_t, ω' = v_t'/R. Tangential restitution v_t'/v_t, rebound angle
atan(v_t'/(e·v_n)), spin |ω'|.

The normal restitution: the zoo's Hunt–Crossley model with nominal e = 0.98 sets
α = b·v_n = 1.5·(1 − 0.98) = 0.03 at every angle (Hunt & Crossley 1975's linearised α;
:mod:`impactbench.reference.models`), so e is one number: the root w of G(−w) = G(1) with
G(u) = (u − ln(1 + α·u)/α)/α, the energy integral of m·ẍ = −c·xⁿ·(1 + b·ẋ) over
compression and restitution (c, n and m drop out).

The case (Chung & Ooi 2011, test 4): V = 3.9 m/s, μ = 0.092, R = 2.5 mm.
"""

from __future__ import annotations

import csv
import math
from importlib import resources

import numpy as np
import pytest
from scipy import optimize

V_M_S = 3.9
MU = 0.092
RADIUS_M = 0.0025
NOMINAL_E = 0.98
QUANTITY = {"tangential_restitution_com": "tangential_restitution",
            "spin_out_abs": "spin_out_rad_s", "rebound_angle_com": "rebound_angle_deg"}
"""The CSV's quantity names → the metrics the pins use."""


def measured() -> list[tuple[str, float, float]]:
    """(metric, incidence angle °, measured value) of every row of the packaged CSV."""
    path = resources.files("impactbench.reference").joinpath("data/kharaz2001/kharaz2001.csv")
    with path.open() as fh:
        return [(QUANTITY[row["quantity"]], float(row["incidence_angle_deg"]),
                 float(row["value"])) for row in csv.DictReader(fh)]


def hunt_crossley_restitution(alpha: float) -> float:
    def g(u: float) -> float:
        return (u - math.log1p(alpha * u) / alpha) / alpha

    return optimize.brentq(lambda w: g(-w) - g(1.0), 1e-9, 1.0 - 1e-15, xtol=1e-16)


def rigid(angle_deg: float, e: float) -> dict[str, float]:
    th = math.radians(angle_deg)
    v_n, v_t = V_M_S * math.cos(th), V_M_S * math.sin(th)
    impulse = MU * (1.0 + e) * v_n
    if v_t > 3.5 * impulse:
        vt_out, spin = v_t - impulse, 2.5 * impulse / RADIUS_M
    else:
        vt_out = 5.0 / 7.0 * v_t
        spin = vt_out / RADIUS_M
    return {"tangential_restitution": vt_out / v_t if v_t else math.nan,
            "rebound_angle_deg": math.degrees(math.atan2(vt_out, e * v_n)),
            "spin_out_rad_s": abs(spin)}


def rms(lo: float, hi: float) -> dict[str, float]:
    e = hunt_crossley_restitution(1.5 * (1.0 - NOMINAL_E))
    errors: dict[str, list[float]] = {}
    for metric, angle, value in measured():
        if lo <= angle < hi:
            errors.setdefault(metric, []).append(rigid(angle, e)[metric] - value)
    return {m: float(np.sqrt(np.mean(np.square(x)))) for m, x in errors.items()}


def test_the_restitution_is_the_packages() -> None:
    """The energy integral's e for α = 0.03 (0.98039 for the nominal 0.98: Hunt & Crossley's
    linearised α damps a little less) is the package's Lambert-W closed form to round-off
    (measured 1.6e-15)."""
    from impactbench.reference import hunt_crossley

    e = hunt_crossley_restitution(0.03)
    assert e == pytest.approx(float(hunt_crossley.restitution(0.03)), rel=1e-12)
    assert 0.9803 < e < 0.9805


def test_the_pinned_rigid_rms_rows_are_the_closed_forms() -> None:
    """Every rigid RMS pinned in test_oblique_microslip.py (its ``RMS`` and ``TOL``: the
    rounding of the pinned numbers) from this independent path."""
    from test_oblique_microslip import RMS, TOL

    for (lo, hi), row in RMS.items():
        got = rms(lo, hi)
        assert set(got) == set(row), (lo, hi)
        for metric, (rigid_rms, _no_slip, _md) in row.items():
            assert got[metric] == pytest.approx(rigid_rms, abs=TOL[metric]), (lo, hi, metric)


PINNED_TEST_OBLIQUE = {
    # test_oblique.py: test_kharaz_low_angles_… (θ < 35°, asserted) and its docstring's table
    # (5°–35°, < 5°), test_kharaz_high_angles_… (θ ≥ 35°, asserted); rigid column; tolerance
    # the pinned rounding
    (0.0, 35.0): {"spin_out_rad_s": (93.06, 0.01), "rebound_angle_deg": (1.408, 1e-3),
                  "tangential_restitution": (0.0685, 1e-4)},
    (5.0, 35.0): {"spin_out_rad_s": (93.06, 0.01), "rebound_angle_deg": (1.989, 1e-3),
                  "tangential_restitution": (0.0736, 1e-4)},
    (0.0, 5.0): {"rebound_angle_deg": (0.104, 1e-3), "tangential_restitution": (0.0601, 1e-4)},
    (35.0, 90.0): {"spin_out_rad_s": (31.04, 0.01), "rebound_angle_deg": (0.5165, 1e-3),
                   "tangential_restitution": (0.0055, 1e-4)},
}


def test_the_rigid_rms_of_test_oblique_are_the_closed_forms() -> None:
    for (lo, hi), row in PINNED_TEST_OBLIQUE.items():
        got = rms(lo, hi)
        for metric, (pinned, tol) in row.items():
            assert got[metric] == pytest.approx(pinned, abs=tol), (lo, hi, metric, got[metric])


def test_the_data_has_the_papers_points() -> None:
    """8 tangential restitutions, 7 spins, 9 rebound angles (the CSV's README), angles 0°–61°."""
    rows = measured()
    counts = {m: sum(r[0] == m for r in rows) for m in QUANTITY.values()}
    assert counts == {"tangential_restitution": 8, "spin_out_rad_s": 7, "rebound_angle_deg": 9}
    assert min(r[1] for r in rows) >= 0.0 and max(r[1] for r in rows) < 61.0
