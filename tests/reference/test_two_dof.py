"""The rigid–flexible 2-DOF reference solver (MODELS.md §2) against limits, invariants and an
independent exact solution."""

from __future__ import annotations

import math

import numpy as np
import pytest
from impactbench.reference import metrics, two_dof
from impactbench.reference.record import Status
from impactbench.reference.scenarios import RigidFlexible
from scipy import integrate, linalg, optimize

COMBOS = two_dof.ALL_COMBOS
KEYS = two_dof.METRIC_KEYS


def rel(a: float, b: float) -> float:
    return abs(a - b) / abs(b)


def energy_history(rec, sc: RigidFlexible) -> np.ndarray:
    """Mechanical energy (J) of a linear-contact record at every sample."""
    structure = sc.structural_law()
    x2 = rec.displacement_2_m
    pot = np.array([structure.potential(x) for x in x2])
    contact = 0.5 * sc.k1_n_per_m * np.maximum(rec.penetration_m, 0.0) ** 2
    return (0.5 * sc.m1_kg * rec.velocity_1_m_s**2 + 0.5 * sc.m2_kg * rec.velocity_2_m_s**2
            + pot + contact)


# --- limits and invariants -------------------------------------------------------------------

@pytest.mark.parametrize("limit", [{"m2_kg": 1e12}, {"k2_n_per_m": 1e13}])
@pytest.mark.parametrize("v1", [0.5, 20.0])
def test_rigid_wall_limit(limit, v1):
    sc = RigidFlexible(velocity_m_s=v1, **limit)
    m1, k1 = sc.m1_kg, sc.k1_n_per_m
    r = two_dof.solve(sc)
    assert r["status"] == "ok" and r["impacts"] == 1
    assert rel(r["pulse_width_s"], math.pi * math.sqrt(m1 / k1)) < 1e-6
    assert rel(r["peak_force_n"], v1 * math.sqrt(k1 * m1)) < 1e-6
    assert rel(r["impulse_ns"], 2 * m1 * v1) < 1e-6


def test_rigid_wall_limit_through_the_record():
    sc = RigidFlexible(velocity_m_s=3.0, m2_kg=1e12)
    m = metrics.compute(two_dof.simulate(sc))
    assert rel(m["pulse_width_s"], math.pi * math.sqrt(sc.m1_kg / sc.k1_n_per_m)) < 1e-6
    assert rel(m["peak_force_n"], 3.0 * math.sqrt(sc.k1_n_per_m * sc.m1_kg)) < 1e-6
    assert rel(m["impulse_ns"], 2 * sc.m1_kg * 3.0) < 1e-6


@pytest.mark.parametrize("structure", ["linear", "softening"])
@pytest.mark.parametrize("v1", [2.0, 10.0])
def test_energy_conserved_for_linear_contact(structure, v1):
    sc = RigidFlexible(velocity_m_s=v1, structure=structure)
    rec = two_dof.simulate(sc)
    e = energy_history(rec, sc)
    e0 = 0.5 * sc.m1_kg * v1**2
    assert np.max(np.abs(e - e0)) <= 1e-8 * e0
    assert abs(two_dof.solve(sc)["dissipated_energy_j"]) <= 1e-8 * e0


@pytest.mark.parametrize(("local", "structure"), COMBOS)
@pytest.mark.parametrize("v1", [1.0, 10.0])
def test_impulse_equals_momentum_change_of_body_1(local, structure, v1):
    sc = RigidFlexible(velocity_m_s=v1, local=local, structure=structure)
    rec = two_dof.simulate(sc)
    assert rec.status is Status.OK
    m = metrics.compute(rec)
    dv1 = v1 - rec.velocity_1_m_s[-1]
    assert rel(m["impulse_ns"], sc.m1_kg * dv1) < 1e-7


@pytest.mark.parametrize("structure", ["linear", "softening"])
def test_elastoplastic_below_yield_equals_linear(structure):
    lin = RigidFlexible(velocity_m_s=2.0, structure=structure)
    ep = lin.replace(local="elastoplastic")
    rec = two_dof.simulate(ep)
    assert np.max(rec.penetration_m) < ep.eps_s_m  # the premise: no yield
    a, b = two_dof.solve(lin), two_dof.solve(ep)
    for k in KEYS:
        assert rel(b[k], a[k]) < 1e-12, k
    assert abs(b["dissipated_energy_j"]) < 1e-9 * b["initial_energy_j"]


@pytest.mark.parametrize(("local", "v1"), [("elastoplastic", 10.0), ("elastoplastic", 15.0),
                                           ("elastoplastic", 40.0), ("mutation", 5.0)])
def test_dissipated_energy_equals_hysteresis_area(local, v1):
    sc = RigidFlexible(velocity_m_s=v1, local=local)
    rec = two_dof.simulate(sc)
    area = float(np.trapezoid(rec.normal_force_n, rec.penetration_m))  # exact: F affine in Δx
    r = two_dof.solve(sc)
    assert r["dissipated_energy_j"] > 1e-3 * r["initial_energy_j"]  # something yielded
    assert abs(area - r["dissipated_energy_j"]) <= 1e-8 * r["initial_energy_j"]


def test_multiple_impacts_after_yield():
    r = two_dof.solve(RigidFlexible(velocity_m_s=10.0, local="elastoplastic"))
    assert r["impacts"] >= 2 and r["pulse_width_s"] > r["contact_time_s"]


# --- an independent exact solution of linear/linear -------------------------------------------

def exact_linear_linear(sc: RigidFlexible) -> dict[str, float]:
    """Matrix-exponential solution of each contact and free phase, event times by brentq."""
    m1, m2, k1, k2 = sc.m1_kg, sc.m2_kg, sc.k1_n_per_m, sc.k2_n_per_m

    def system(contact: bool) -> np.ndarray:
        k = k1 if contact else 0.0
        return np.array([[0, 0, 1, 0], [0, 0, 0, 1],
                         [-k / m1, k / m1, 0, 0], [k / m2, -(k + k2) / m2, 0, 0]], dtype=float)

    y = np.array([0.0, 0.0, sc.velocity_m_s, 0.0])
    t, contact, starts, ends, peak = 0.0, True, [0.0], [], 0.0
    for _ in range(50):
        a = system(contact)
        w = math.sqrt(k1 / m1 + (k1 + k2) / m2) if contact else math.sqrt(k2 / m2)
        h = 0.01 / w
        y0 = y.copy()

        def at(s: float, a: np.ndarray = a, y0: np.ndarray = y0) -> np.ndarray:
            return linalg.expm(a * s) @ y0

        def gap(s: float, at=at) -> float:
            z = at(s)
            return z[0] - z[1]

        def rate_at(s: float, at=at) -> float:
            z = at(s)
            return z[2] - z[3]

        reach = math.sqrt((m2 * y[3] ** 2 + k2 * y[1] ** 2) / k2)
        s, g_old, found = 0.0, None, None
        step = linalg.expm(a * h)
        yy = y0
        while found is None:
            s1 = s + h
            yy = step @ yy  # march on the grid; brentq refines from the phase start
            dx = yy[0] - yy[1]
            if not contact and yy[2] <= 0 and yy[0] < -reach:
                break  # body 1 is beyond body 2's reach, moving away
            if contact and dx <= 0.0:
                found = optimize.brentq(gap, s, s1,
                                        xtol=1e-15, rtol=1e-15)
            elif not contact and dx >= 0.0:
                found = optimize.brentq(gap, s, s1,
                                        xtol=1e-15, rtol=1e-15)
            elif contact:
                rate = yy[2] - yy[3]
                if g_old is not None and g_old > 0.0 >= rate:
                    tp = optimize.brentq(rate_at, s, s1,
                                         xtol=1e-15, rtol=1e-15)
                    z = at(tp)
                    peak = max(peak, k1 * (z[0] - z[1]))
                g_old = rate
            s = s1
        if found is None:
            break
        y = at(found)
        t += found
        (ends if contact else starts).append(t)
        contact = not contact
    return {
        "peak_force_n": peak,
        "pulse_width_s": ends[-1] - starts[0],
        "contact_time_s": sum(e - s for s, e in zip(starts, ends, strict=True)),
        "impulse_ns": m1 * (sc.velocity_m_s - y[2]),
        "impacts": len(starts),
    }


@pytest.mark.parametrize("changes", [{}, {"m2_kg": 3.0}, {"k2_n_per_m": 2e4},
                                     {"k1_n_per_m": 1e4, "velocity_m_s": 7.0}])
def test_linear_linear_matches_exact_piecewise_solution(changes):
    sc = RigidFlexible(**changes)
    exact = exact_linear_linear(sc)
    for r in (two_dof.solve(sc), two_dof.solve_slow(sc)):
        assert r["impacts"] == exact["impacts"]
        for k in ("peak_force_n", "pulse_width_s", "contact_time_s", "impulse_ns"):
            assert rel(r[k], exact[k]) < 1e-7, k


# --- the fast path equals the one metrics path ------------------------------------------------

@pytest.mark.parametrize(("local", "structure"), COMBOS)
def test_fast_path_equals_metrics_of_simulate(local, structure):
    for v1 in (0.3, 2.0, 10.0, 12.5, 300.0):
        sc = RigidFlexible(velocity_m_s=v1, local=local, structure=structure)
        fast = two_dof.solve_fast(sc)
        rec = two_dof.simulate(sc)
        m = metrics.compute(rec)
        assert fast["status"] == str(rec.status)
        assert fast["impacts"] == m["impacts"]
        for k in ("peak_force_n", "pulse_width_s", "contact_time_s", "impulse_ns"):
            assert rel(fast[k], m[k]) < 1e-7, (v1, k)


def test_events_are_located_to_1e10_s():
    sc = RigidFlexible(velocity_m_s=10.0, local="elastoplastic")
    rec = two_dof.simulate(sc)
    kinds = [e[1] for e in rec.meta["events"]]
    assert {"yield", "turn", "end", "start"} <= set(kinds)
    law = sc.local_law()
    for t_ev, kind, _ in rec.meta["events"]:
        i = int(np.argmin(np.abs(rec.time_s - t_ev)))
        dx, rate = rec.penetration_m[i], rec.penetration_rate_m_s[i]
        if kind == "yield":
            assert abs(dx - sc.eps_s_m) / abs(rate) <= 1e-10
        if kind == "turn":
            law.update(dx)
            f, x2 = rec.normal_force_n[i], rec.displacement_2_m[i]
            accel = -f / sc.m1_kg - (f - sc.k2_n_per_m * x2) / sc.m2_kg  # d(Δẋ)/dt
            assert abs(rate / accel) <= 1e-10
        if kind in ("end", "start") and t_ev > 0:
            assert abs(dx - law.contact_threshold()) / abs(rate) <= 1e-10


# --- convergence ------------------------------------------------------------------------------

@pytest.mark.parametrize(("local", "structure"), COMBOS)
def test_converged_when_tolerances_tightened_100x(local, structure):
    from impactbench.reference import two_dof_fast

    sc = RigidFlexible(velocity_m_s=10.0, local=local, structure=structure)
    a = two_dof.solve_slow(sc)
    b = two_dof.solve_slow(sc, rtol=two_dof.RTOL / 100, atol=two_dof.ATOL_M / 100)
    # fast path: an 8th-order method's local error falls 100× with the step ÷ 100^(1/8)
    f1 = two_dof_fast.run(sc)
    f2 = two_dof_fast.run(sc, step_rad=two_dof_fast.STEP_RAD / 100 ** (1 / 8))
    for i, k in enumerate(KEYS):
        assert rel(b[k], a[k]) < 1e-7, k
        assert abs(f2[i + 1] - f1[i + 1]) <= 1e-7 * abs(f1[i + 1]), k


# --- end rules and bad input ------------------------------------------------------------------

@pytest.mark.parametrize("local", ["linear", "elastoplastic", "mutation"])
def test_collapsed_run_goes_on_until_body_2_escapes(local):
    sc = RigidFlexible(velocity_m_s=300.0, local=local, structure="softening")
    rec = two_dof.simulate(sc)
    assert rec.status is Status.STRUCTURE_COLLAPSED
    structure = sc.structural_law()
    events = rec.meta["events"]
    kinds = [e[1] for e in events]
    assert kinds.count("collapse") == 1 and kinds[-1] == "done" and kinds[-2] == "end"
    i = int(np.searchsorted(rec.time_s, events[kinds.index("collapse")][0]))
    e2 = 0.5 * sc.m2_kg * rec.velocity_2_m_s[i] ** 2 + structure.potential(
        rec.displacement_2_m[i])
    assert rel(e2, structure.collapse_energy) < 1e-9  # collapse located where E2 = k2²/(4β)
    # the end: out of contact, body 2 past the potential's peak and outrunning body 1
    x1, x2, v1, v2 = rec.meta["final_state"]
    assert rec.normal_force_n[-1] <= 1e-10 * np.max(rec.normal_force_n)
    assert x2 > structure.collapse_displacement and v2 >= max(v1, 0.0)
    # ... so the free motion from there never closes the gap (independent check: free
    # flight integrated until x2 is 20× past the peak)
    m2, xc = sc.m2_kg, structure.collapse_displacement
    sol = integrate.solve_ivp(lambda _t, s: [s[1], -structure.force(s[0]) / m2], (0.0, 10.0),
                              [x2, v2], rtol=1e-10, atol=1e-12, dense_output=True,
                              events=lambda _t, s: s[0] - 20.0 * xc)
    t = np.linspace(0.0, sol.t[-1], 2001)
    assert np.all(x1 + v1 * t - sol.sol(t)[0] < x1 - x2 + 1e-12)
    # the metrics describe the whole contact, and the fast path agrees
    m = metrics.compute(rec)
    assert rel(m["impulse_ns"], sc.m1_kg * (300.0 - v1)) < 1e-7
    fast = two_dof.solve_fast(sc)
    assert fast["status"] == "structure_collapsed" and fast["impacts"] == m["impacts"]
    for k in ("peak_force_n", "pulse_width_s", "contact_time_s", "impulse_ns"):
        assert rel(fast[k], m[k]) < 1e-7, k


def test_no_collapse_below_the_potential_peak():
    # 10 m/s: 500 J < k2²/(4β) = 833 J, so the structure cannot collapse
    r = two_dof.solve(RigidFlexible(velocity_m_s=10.0, structure="softening"))
    assert r["status"] == "ok"


def test_time_cap_is_reported():
    sc = RigidFlexible(velocity_m_s=2.0, max_time_s=0.01)
    assert two_dof.simulate(sc).status is Status.MAX_TIME
    r = two_dof.solve(sc)
    assert r["status"] == "max_time" and r["pulse_width_s"] == pytest.approx(0.01)


def test_bad_inputs_raise_one_line_errors():
    with pytest.raises(ValueError, match=r"^velocity_m_s = -1.0: must be > 0"):
        RigidFlexible(velocity_m_s=-1.0)
    with pytest.raises(ValueError, match=r"local = 'plastic'.*did you mean"):
        RigidFlexible(local="plastic")
    with pytest.raises(ValueError, match=r"^over = 'mass'"):
        two_dof.sweep(RigidFlexible(), "mass", [1.0])
    with pytest.raises(ValueError, match=r"^m2_kg = 0.0: must be > 0"):
        two_dof.sweep(RigidFlexible(), "m2", [0.0])
    with pytest.raises(ValueError, match=r"^scenario = "):
        two_dof.simulate("not a scenario")  # type: ignore[arg-type]


def test_sweep_is_ordered_and_matches_solve():
    values = [1.0, 3.0, 20.0]
    df = two_dof.sweep(RigidFlexible(), "velocity", values)
    assert list(df.columns) == ["local", "structure", "velocity_m_s", *KEYS, "status"]
    assert len(df) == 6 * len(values)
    assert list(zip(df["local"], df["structure"], strict=True))[::3] == list(COMBOS)
    row = df.iloc[5]
    r = two_dof.solve(RigidFlexible(velocity_m_s=20.0, local=row["local"],
                                    structure=row["structure"]))
    assert row["velocity_m_s"] == 20.0 and row["peak_force_n"] == r["peak_force_n"]


def test_sweep_tasks_are_fixed_chunks_in_combo_then_value_order():
    values = np.arange(1, two_dof.SWEEP_CHUNK + 2, dtype=float)  # one full chunk and one value
    tasks = two_dof.sweep_tasks(RigidFlexible(), "m2", values, [("mutation", "softening")])
    assert [len(t[2]) for t in tasks] == [two_dof.SWEEP_CHUNK, 1]
    assert {(t[0].local, t[0].structure, t[1]) for t in tasks} == {("mutation", "softening",
                                                                      "m2")}
    assert tasks[0][2] + tasks[1][2] == list(values)
