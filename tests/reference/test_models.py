"""The contact-model zoo: each model's exact restitution against an independent ODE solve."""

from __future__ import annotations

import math

import pytest
from impactbench.reference import hunt_crossley as hc
from impactbench.reference import kelvin_voigt, metrics, zoo
from impactbench.reference.models import (
    HYSTERESIS_MODELS,
    LINEAR_MODELS,
    MODELS,
    KelvinVoigt,
    spring_damper,
)
from impactbench.reference.scenarios import BallOnPlate
from impactbench.reference.zoo import effective_restitution
from scipy import integrate

NOMINAL = (0.2, 0.5, 0.8, 0.95)


def ode(rhs, force, rtol: float = 1e-13) -> dict[str, float]:
    """Independent dimensionless impact ξ'' = rhs, from ξ = 0, ξ' = 1, written out here:
    DOP853, contact ends at ξ = 0 or where ``force`` falls to 0 (a clipped law lets go)."""

    def leave(_t, y):
        return y[0]

    def let_go(_t, y):
        return force(y)

    leave.terminal, leave.direction = True, -1.0
    let_go.terminal, let_go.direction = True, -1.0
    sol = integrate.solve_ivp(lambda t, y: [y[1], rhs(y)], (0.0, 1e3), [1e-300, 1.0],
                              method="DOP853", rtol=rtol, atol=rtol * 1e-3,
                              events=(leave, let_go))
    return {"restitution": -float(sol.y[1, -1]), "duration": float(sol.t[-1])}


def hysteresis_ode(alpha: float, n: float = 1.5) -> dict[str, float]:
    """ξ'' = −ξⁿ(1 + α·ξ') in units x* = (m·V0²/c)^(1/(n+1)), t* = x*/V0."""
    return ode(lambda y: -max(y[0], 0.0) ** n * (1.0 + alpha * y[1]),
               lambda y: 1.0)  # F = f(x)(1 + bẋ) > 0 on every trajectory: ends at ξ = 0


def linear_ode(zeta: float, clipped: bool) -> dict[str, float]:
    """ξ'' = −(ξ + 2ζ·ξ') in units x* = V0/ωn, t* = 1/ωn."""
    return ode(lambda y: -(y[0] + 2.0 * zeta * y[1]),
               (lambda y: y[0] + 2.0 * zeta * y[1]) if clipped else (lambda y: 1.0))


@pytest.mark.parametrize("model", MODELS)
def test_effective_restitution_matches_an_independent_ode(model):
    for e in NOMINAL:
        if model in HYSTERESIS_MODELS:
            want = hysteresis_ode(HYSTERESIS_MODELS[model].alpha(e))["restitution"]
        else:
            zeta = -math.log(e) / math.hypot(math.pi, math.log(e))
            want = linear_ode(zeta, LINEAR_MODELS[model])["restitution"]
        assert effective_restitution(model, e) == pytest.approx(want, rel=1e-8, abs=0.0), e


def test_unclipped_kelvin_voigt_is_exact_and_clipping_raises_restitution():
    for e in NOMINAL:
        assert effective_restitution("kelvin-voigt", e) == pytest.approx(e, rel=1e-14)
        assert effective_restitution("kelvin-voigt-clipped", e) > e
    assert effective_restitution("lankarani-nikravesh", 1.0) == 1.0


@pytest.mark.parametrize("clipped", [True, False])
@pytest.mark.parametrize("e", [0.1, 0.5, 0.9])
def test_kelvin_voigt_closed_form_matches_ode_duration_and_history(clipped, e):
    m, k, v0 = 0.05, 2e5, 1.5
    d = 2.0 * kelvin_voigt.zeta_from_restitution(e) * math.sqrt(k * m)
    got = kelvin_voigt.solve(m, k, d, v0, clipped)
    ref = linear_ode(d / (2.0 * math.sqrt(k * m)), clipped)
    wn = math.sqrt(k / m)
    assert got["duration_s"] == pytest.approx(ref["duration"] / wn, rel=1e-9)
    assert got["restitution"] == pytest.approx(ref["restitution"], rel=1e-9)
    if clipped:  # the metrics path defines contact by F > 0: the clipped law only
        rec = kelvin_voigt.history(m, k, d, v0, clipped)
        from_record = metrics.compute(rec)
        assert from_record["peak_force_n"] == pytest.approx(got["peak_force_n"], rel=1e-12)
        assert from_record["restitution"] == pytest.approx(got["restitution"], rel=1e-8)
        assert from_record["duration_s"] == pytest.approx(got["duration_s"], rel=1e-6)


@pytest.mark.parametrize("model", ["hunt-crossley", "flores", "gonthier", "lee-wang"])
def test_hysteresis_models_are_hunt_crossley_with_derived_damping(model):
    s = BallOnPlate(velocity_m_s=2.0, model=model, nominal_restitution=0.6)
    alpha = HYSTERESIS_MODELS[model].alpha(0.6)
    assert s.damping_s_per_m == pytest.approx(alpha / 2.0, rel=1e-15)
    assert s.law().damping == s.damping_s_per_m
    assert s.replace(velocity_m_s=4.0).damping_s_per_m == pytest.approx(alpha / 4.0)
    rec = metrics.compute(hc.history(s))
    ref = hc.solve(s)
    assert ref["restitution"] == pytest.approx(effective_restitution(model, 0.6), rel=1e-14)
    for key in ("restitution", "peak_force_n", "duration_s"):
        assert rec[key] == pytest.approx(ref[key], rel=1e-7)


def test_sweep_scales_one_dimensionless_solve():
    s = BallOnPlate(model="zhiying-qishao", nominal_restitution=0.7)
    table = zoo.sweep(s, [0.5, 2.0, 5.0])
    for row in table.itertuples():
        want = hc.solve(s.replace(velocity_m_s=row.velocity_m_s))
        assert row.duration_s == pytest.approx(want["duration_s"], rel=1e-12)
        assert row.peak_force_n == pytest.approx(want["peak_force_n"], rel=1e-12)
    lin = BallOnPlate(model="kelvin-voigt-clipped", nominal_restitution=0.7, exponent=1.0,
                      stiffness=1e6)
    assert zoo.sweep(lin, [1.0, 3.0])["duration_s"].nunique() == 1  # linear: T(V0) constant


def test_restitution_table_covers_every_model():
    table = zoo.restitution_table([0.2, 0.5, 0.8])
    assert set(table["model"]) == set(MODELS)
    assert len(table) == 3 * len(MODELS)
    ln = table[table.model == "lankarani-nikravesh"]
    assert (ln.effective_restitution > ln.nominal_restitution).all()  # LN overshoots


def test_spring_damper_form_of_each_family():
    s = BallOnPlate(model="flores", nominal_restitution=0.5)
    law = s.law()
    k, d = spring_damper(law, 1e-5)
    assert k * 1e-5 + d * 0.3 == pytest.approx(law.force(1e-5, 0.3), rel=1e-14)
    kv = KelvinVoigt(1e5, 30.0, clipped=False)
    assert spring_damper(kv, 1e-3) == (1e5, 30.0)
    assert kv.force(1e-4, -1.0) < 0.0 and kv.adhesive
    assert KelvinVoigt(1e5, 30.0).force(1e-4, -1.0) == 0.0


@pytest.mark.parametrize(("changes", "message"), [
    ({"model": "flores"}, "nominal_restitution = None: model 'flores' needs"),
    ({"model": "flores", "nominal_restitution": 1.2}, "nominal_restitution = 1.2: must be in"),
    ({"model": "flores", "nominal_restitution": 0.0}, "nominal_restitution = 0.0: must be > 0"),
    ({"model": "kelvin-voigt", "nominal_restitution": 0.5}, "exponent = 1.5: model"),
    ({"model": "hunt-crosley"}, "did you mean 'hunt-crossley'"),
])
def test_bad_model_input_is_one_line(changes, message):
    with pytest.raises(ValueError, match=message.replace("(", r"\(")):
        BallOnPlate(**changes)


def test_laws_name_their_bad_fields():
    from impactbench.reference.models import Flores

    with pytest.raises(ValueError, match=r"^nominal_restitution = 1.5: must be in \(0, 1\]$"):
        Flores(nominal_restitution=1.5)
    with pytest.raises(ValueError, match=r"^nominal_restitution = 0.0: must be > 0"):
        Flores(nominal_restitution=0.0)
    with pytest.raises(ValueError, match=r"^velocity_m_s = 0.0: must be > 0"):
        Flores(nominal_restitution=0.5, velocity_m_s=0.0)
    with pytest.raises(ValueError, match=r"^stiffness = -1.0: must be > 0"):
        KelvinVoigt(-1.0, 1.0)
    with pytest.raises(ValueError, match=r"^damping_ns_per_m = -1.0: must be >= 0"):
        KelvinVoigt(1.0, -1.0)


@pytest.mark.parametrize("clipped", [True, False])
def test_kelvin_voigt_law_values(clipped):
    kv = KelvinVoigt(1e5, 30.0, clipped=clipped)
    for x, rate in ((0.0, 1.0), (0.0, -1.0), (-1e-3, 1.0), (-1e-3, -1.0)):
        assert kv.force(x, rate) == 0.0, (x, rate)  # out of contact (x ≤ 0): no force
    assert kv.force(1e-3, 2.0) == pytest.approx(100.0 + 60.0, rel=1e-15)  # k·x + d·ẋ
    assert kv.elastic_force(1e-3) == 1e5 * 1e-3
    assert kv.elastic_force(0.0) == 0.0 and kv.elastic_force(-1e-3) == 0.0
    assert kv.potential(1e-3) == pytest.approx(0.05, rel=1e-15)  # ½·k·x²
    assert kv.potential(0.0) == 0.0 and kv.potential(-1e-3) == 0.0
