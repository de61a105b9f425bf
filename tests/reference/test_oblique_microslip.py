"""The Mindlin–Deresiewicz (micro-slip) reference of the oblique impact
(``tangential = "mindlin-deresiewicz"``, :func:`impactbench.reference.oblique_integrate.
micro_slip`): the spring bed against the constant-F_n Cattaneo–Mindlin and
Mindlin–Deresiewicz curves, its convergence, its limits (μ → ∞: Mindlin's no-slip loading;
gross sliding: the rigid theory), energy, and Kharaz et al.'s measurements by angle range
against the rigid theory and the no-slip law."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest
from impactbench.reference import kharaz2001, oblique
from impactbench.reference import oblique_integrate as oi
from impactbench.reference.oblique import OBLIQUE_METRICS, Oblique
from oblique_checks import assert_record_metrics_match

MD = "mindlin-deresiewicz"
COARSE = {"springs": oi.MD_SPRINGS // 2, "steps": oi.MD_STEPS // 2}
"""Half the default bed and steps: ~5e-8 from converged (test_converges), 3× faster."""


# ------------------------------------------------------------------ the bed at constant F_n


def _bed_at(springs: int) -> tuple[oi.SpringBed, float, float, float]:
    """A bed at a fixed indentation of Kharaz's sphere: (bed, μ·F_n, a, G*)."""
    s = Oblique.kharaz2001()
    r, c, g = s.radius_m, s.stiffness, s.shear_modulus_pa
    x = 1e-6
    a = math.sqrt(r * x)
    bed = oi.SpringBed(r, 3.0 * c / (4.0 * math.sqrt(r)), 4.0 * g, s.friction, a, springs)
    return bed, s.friction * c * x**1.5, a, g


def test_bed_reproduces_cattaneo_mindlin_and_mindlin_deresiewicz_at_constant_load():
    """At a constant normal force the bed follows Cattaneo–Mindlin's first loading
    T = μN·(1 − (1 − δ/δ_s)^(3/2)), δ_s = 3μN/(16·G*·a) (so the stiffness is
    8·G*·a·(1 − T/μN)^(1/3)), then Mindlin–Deresiewicz's unloading from T* (Masing:
    T = T* − 2·f((δ* − δ)/2)) and reloading, to 1.34e-7 of μN with 2000 springs (measured;
    2.3e-6 with 500, 9.2e-9 with 8000: second order)."""
    bed, mun, a, g = _bed_at(2000)
    d_s = 3.0 * mun / (16.0 * g * a)

    def virgin(d: float) -> float:
        return math.copysign(mun * (1.0 - (1.0 - abs(d) / d_s) ** 1.5), d)

    top = 0.8 * d_s
    path = [("load", d) for d in np.linspace(0.0, top, 201)[1:]]
    path += [("unload", d) for d in np.linspace(top, -top, 401)[1:]]
    path += [("reload", d) for d in np.linspace(-top, top, 401)[1:]]
    prev, worst = 0.0, 0.0
    for phase, d in path:
        got = -bed.advance(1e-6, 1.0, d - prev, 1.0)  # the force on the plate, along +δ
        prev = d
        want = {"load": virgin(d), "unload": virgin(top) - 2.0 * virgin((top - d) / 2.0),
                "reload": virgin(-top) + 2.0 * virgin((d + top) / 2.0)}[phase]
        worst = max(worst, abs(got - want) / mun)
    assert worst < 4e-7
    bed, _, a, g = _bed_at(2000)
    step = 1e-9 * d_s
    assert -bed.advance(1e-6, 1.0, step, 1.0) / step == pytest.approx(8.0 * g * a, rel=1e-12)


# ------------------------------------------------------------------ the impact


@pytest.mark.parametrize("angle", [3.7, 20.0])
def test_converges_at_second_order(angle):
    """Doubling springs and steps together from (1000, 5000): the changes fall by ~4 per
    doubling; the defaults are within 1e-7 of the finest (measured at 3.7°: e_t changes 5.2e-8
    then 1.4e-8 of itself, spin 1.6e-7 then 4.4e-8; at 20° ≤ 3e-9)."""
    s = Oblique.kharaz2001(angle_deg=angle, tangential=MD)
    runs = [oi.mindlin_deresiewicz(s, n, k) for n, k in ((1000, 5000), (2000, 10000),
                                                         (4000, 20000))]
    for key in ("tangential_restitution", "spin_out_rad_s", "rebound_angle_deg"):
        a, b, c = (r[key] for r in runs)
        assert abs(b - c) <= 1e-7 * abs(c), key
        assert abs(b - c) <= 0.5 * abs(a - b) + 1e-11 * abs(c), key
    default = oi.mindlin_deresiewicz(s)
    assert close_all(default, runs[1], rel=0.0)


def close_all(a: dict, b: dict, rel: float) -> bool:
    return all((math.isnan(a[k]) and math.isnan(b[k])) or a[k] == pytest.approx(b[k], rel=rel)
               for k in OBLIQUE_METRICS)


@pytest.mark.parametrize("angle", [5.0, 30.0, 60.0])
def test_normal_part_is_the_closed_form(angle):
    s = Oblique.kharaz2001(angle_deg=angle, tangential=MD)
    got, want = oi.mindlin_deresiewicz(s, **COARSE), oblique.rigid(s)
    for k in ("restitution", "duration_s", "peak_force_n"):
        assert got[k] == pytest.approx(want[k], rel=1e-10)


@pytest.mark.parametrize(("angle", "spin"), [(60.0, 0.0), (80.0, 0.0), (30.0, -600.0),
                                             (30.0, 2000.0)])
def test_gross_sliding_throughout_is_the_rigid_theory(angle, spin):
    """Sliding the whole contact (no spin, backspin, topspin beyond rolling) every spring is
    at its limit: F_t = μ·F_n, the rigid theory (measured ≤ 2e-10 at 60°; the spin after the
    backspin, 15.4 rad/s, to 1.5e-8 of itself, 1.5e-10 of V/R)."""
    s = Oblique.kharaz2001(angle_deg=angle, spin_rad_s=spin, tangential=MD)
    got, want = oi.mindlin_deresiewicz(s), oblique.rigid(s)
    assert want["regime"] == oblique.SLIDE
    for k, scale in (("tangential_restitution", 1.0), ("rebound_angle_deg", 90.0),
                     ("spin_out_rad_s", s.velocity_m_s / s.radius_m)):
        assert got[k] == pytest.approx(want[k], rel=1e-8, abs=1e-9 * scale), k


def test_frictionless_and_head_on():
    s = Oblique(friction=0.0, tangential=MD)
    got = oi.mindlin_deresiewicz(s, **COARSE)
    assert got["tangential_restitution"] == 1.0 and got["spin_out_rad_s"] == 0.0
    assert got["peak_tangential_force_n"] == 0.0
    head_on = oi.mindlin_deresiewicz(Oblique(angle_deg=0.0, tangential=MD), **COARSE)
    assert head_on["spin_out_rad_s"] == 0.0 and head_on["peak_tangential_force_n"] == 0.0


def test_mu_to_infinity_loads_as_mindlins_no_slip_law():
    """μ → ∞: no spring reaches its limit while the contact grows, so the loading is exactly
    Mindlin's no-slip law dF_t = −8·G*·a·ds (the ``mindlin`` reference, integrated
    independently): F_t and v_t agree through the compression (measured ≤ 2.8e-7 and 1.3e-8,
    the bed's discretisation). The whole impact approaches its μ = ∞ limit as 1/μ
    (measured e_t differences 3.5e-3, 3.5e-4, 3.5e-5 at μ = 1, 10, 100)."""
    s = Oblique.kharaz2001(angle_deg=3.7, friction=1e12)
    md = oi.micro_slip(s)
    no_slip = oi.integrate_scenario(s.replace(tangential="mindlin"))
    peak = int(np.argmax(md.x))
    for i in (peak // 4, peak // 2, int(0.9 * peak)):
        t = md.time_s[i]
        y = next(seg.sol(t) for seg in no_slip.segments if seg.t0 <= t <= seg.t1)
        assert md.tangential_force_n[i] == pytest.approx(y[4], rel=1e-6)
        assert md.tangential_velocity[i] == pytest.approx(y[2], rel=5e-8)
    limit = md.metrics["tangential_restitution"]
    gaps = [oi.mindlin_deresiewicz(s.replace(friction=mu), **COARSE)["tangential_restitution"]
            - oi.mindlin_deresiewicz(s, **COARSE)["tangential_restitution"]
            for mu in (1.0, 10.0, 100.0)]
    assert gaps[0] == pytest.approx(-3.5e-3, rel=0.05)
    assert gaps[1] == pytest.approx(gaps[0] / 10, rel=0.05)
    assert gaps[2] == pytest.approx(gaps[1] / 10, rel=0.05)
    # ... and that limit is not the ``mindlin`` law's: its unloading (F_t ∝ a) is wrong
    assert limit == pytest.approx(0.79895, abs=1e-4)
    assert oi.mindlin(s.replace(tangential="mindlin"))["tangential_restitution"] \
        == pytest.approx(0.8824, abs=1e-4)


@pytest.mark.parametrize("shape", ["sphere", "disc"])
def test_never_creates_energy(shape):
    """An elastic normal law (e = 1): the kinetic energy after (translation and spin) never
    exceeds the energy before, over angles, spins and friction (measured: the closest is
    7.9e-5 below)."""
    worst = -math.inf
    for mu in (0.092, 100.0):
        for angle, spin in ((1.0, 0.0), (10.0, 0.0), (20.0, 0.0), (45.0, 0.0), (20.0, -300.0),
                            (20.0, 300.0), (0.0, 200.0)):
            s = Oblique.kharaz2001(angle_deg=angle, spin_rad_s=spin, friction=mu,
                                   nominal_restitution=1.0, shape=shape)
            md = oi.micro_slip(s, **COARSE)
            inertia = s.moment_of_inertia_kg_m2
            before = s.mass_kg * s.velocity_m_s**2 + inertia * s.spin_rad_s**2
            after = (s.mass_kg * (md.rate[-1] ** 2 + md.tangential_velocity[-1] ** 2)
                     + inertia * md.spin[-1] ** 2)
            worst = max(worst, after / before - 1.0)
    assert worst < 0.0


def test_record_metrics_of_the_history_match_the_reference():
    assert_record_metrics_match(MD)


def test_bad_settings_one_line():
    s = Oblique(tangential=MD)
    with pytest.raises(ValueError, match=r"^springs = 5: must be an integer >= 10$"):
        oi.micro_slip(s, springs=5)
    with pytest.raises(ValueError, match=r"^tangential = 'mindlin-deresiewicz': must have the "
                                         r"Hertz law"):
        Oblique(tangential=MD, exponent=1.0, model="kelvin-voigt-clipped",
                nominal_restitution=0.8)
    with pytest.raises(ValueError, match=r"^tangential = 'mindlin-deresiewicz': must be one "
                                         r"of rigid, mindlin"):
        oi.integrate_scenario(s)


# ------------------------------------------------------------------ Kharaz et al. (2001)


@pytest.fixture(scope="module")
def errors() -> pd.DataFrame:
    """Per measured point, each reference's signed error (model − data; spin as |ω'|):
    ``rigid``, ``no_slip`` (``mindlin``), ``memory`` (Mindlin–Deresiewicz at μ → ∞: the
    exact no-slip unloading, no micro-slip; the points below 5° only) and ``md``
    (Mindlin–Deresiewicz)."""
    base = Oblique.kharaz2001()
    rows = []
    for p in kharaz2001.load().itertuples():
        s = base.replace(angle_deg=p.angle_deg)
        got = {"rigid": oblique.rigid(s),
               "no_slip": oi.mindlin(s.replace(tangential="mindlin")),
               "md": oi.mindlin_deresiewicz(s, **COARSE),
               "memory": (oi.mindlin_deresiewicz(s.replace(friction=1e12), **COARSE)
                          if p.angle_deg < 5.0 else None)}
        rows.append({"metric": p.metric, "angle_deg": p.angle_deg,
                     **{k: abs(v[p.metric]) - p.value if v else math.nan
                        for k, v in got.items()}})
    return pd.DataFrame(rows)


def _rms(errors: pd.DataFrame, lo: float, hi: float, model: str) -> dict[str, float]:
    sel = errors[(errors.angle_deg >= lo) & (errors.angle_deg < hi)]
    return {m: float(np.sqrt((g[model] ** 2).mean())) for m, g in sel.groupby("metric")}


RMS = {
    # (lo, hi): metric → (rigid, no-slip ``mindlin``, Mindlin–Deresiewicz), measured
    (0.0, 5.0): {"tangential_restitution": (0.06012, 0.11112, 0.01270),  # 2 points
                 "rebound_angle_deg": (0.10348, 0.41435, 0.11135)},  # 3 points
    (5.0, 35.0): {"tangential_restitution": (0.07356, 0.03368, 0.01469),  # 3 points
                  "spin_out_rad_s": (93.061, 45.552, 14.218),  # 4 points
                  "rebound_angle_deg": (1.98861, 0.86988, 0.53362)},  # 3 points
    (35.0, 90.0): {"tangential_restitution": (0.00549, 0.00549, 0.00549),  # 3 points each
                   "spin_out_rad_s": (31.045, 31.045, 31.045),
                   "rebound_angle_deg": (0.51653, 0.51653, 0.51653)},
}
"""Tolerance: 1e-5 (e_t), 1e-3 rad/s, 1e-4°: the rounding of the measured numbers."""
TOL = {"tangential_restitution": 1e-5, "spin_out_rad_s": 1e-3, "rebound_angle_deg": 1e-4}


@pytest.mark.parametrize("span", list(RMS))
def test_kharaz_rms_by_angle_range(errors, span):
    """RMS errors against Kharaz et al. (2001), in the quantity's unit, rigid / no-slip
    (``mindlin``) / Mindlin–Deresiewicz (:data:`RMS`, measured):

    θ < 5°          e_t 0.0601 / 0.1111 / 0.0127     rebound angle 0.104° / 0.414° / 0.111°
    5° ≤ θ < 35°    e_t 0.0736 / 0.0337 / 0.0147     spin 93.1 / 45.6 / 14.2 rad/s
                    rebound angle 1.99° / 0.87° / 0.53°
    θ ≥ 35°         all three the rigid theory: e_t 0.0055, spin 31.0 rad/s, angle 0.52°

    Mindlin–Deresiewicz is the closest in every range and quantity but the rebound angle
    below 5° (0.111° against the rigid 0.104°: both within the points' ±1–2 % reading
    error), and cuts the near-normal tangential-restitution error fivefold. (A Thornton-style
    incremental law — k_t·(1 − ΔF_t/(ζ·μ·F_n))^(1/3) with Masing's reversals, F_t ∝ a
    while the contact shrinks — measured while investigating: e_t 0.0617, rebound angle
    0.230° below 5°; e_t 0.0075, spin 14.4, angle 0.50° in 5°–35°: micro-slip without the
    contact's memory leaves the near-normal error where the rigid theory has it.)"""
    lo, hi = span
    for metric, (rigid, no_slip, md) in RMS[span].items():
        got = {m: _rms(errors, lo, hi, m)[metric] for m in ("rigid", "no_slip", "md")}
        assert got["rigid"] == pytest.approx(rigid, abs=TOL[metric]), metric
        assert got["no_slip"] == pytest.approx(no_slip, abs=TOL[metric]), metric
        assert got["md"] == pytest.approx(md, abs=TOL[metric]), metric
        if lo == 5.0 or (lo == 0.0 and metric == "tangential_restitution"):
            assert got["md"] < 0.7 * min(got["rigid"], got["no_slip"]), metric
        elif lo == 0.0:  # the near-normal rebound angle: Mindlin–Deresiewicz ≈ rigid
            assert got["md"] < 0.3 * got["no_slip"] and got["md"] < 1.1 * got["rigid"]
        else:  # sliding throughout: all three are the rigid theory
            assert got["md"] == pytest.approx(got["rigid"], rel=1e-6)


def test_kharaz_below_5_degrees_it_is_the_unloading_rule_more_than_micro_slip(errors):
    """Why the no-slip law misses the near-normal points: with micro-slip switched off
    (μ → ∞) but each point of the contact leaving with its own displacement, the tangential
    restitution's RMS error below 5° falls from 0.111 to 0.038 (1.8°: 0.799 against 0.793
    measured, the no-slip law's 0.881); micro-slip takes it on to 0.013 (it matters at 3.7°,
    where F_t/μF_n nears 1). Not measurement noise: the Mindlin–Deresiewicz residuals (−0.014
    and +0.012) are the size of the points' ±1–2 % reading error, though e_t = v_t'/v_t has
    only v_t = 0.13 and 0.25 m/s there."""
    near = errors[errors.angle_deg < 5.0]
    e_t = near[near.metric == "tangential_restitution"]
    rms = {m: float(np.sqrt((e_t[m] ** 2).mean())) for m in ("no_slip", "memory", "md")}
    assert rms["no_slip"] == pytest.approx(0.11112, abs=1e-5)
    assert rms["memory"] == pytest.approx(0.03812, abs=1e-5)
    assert rms["md"] == pytest.approx(0.01270, abs=1e-5)
    assert np.all(np.abs(e_t.md) < 0.02 * 0.8)  # within 2 % of the measured ~0.77
