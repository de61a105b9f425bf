"""Compiled fast path of the 2-DOF solver for the built-in laws (numba, optional).

Same physics, pieces, events and end rules as :mod:`impactbench.reference.two_dof` (see there), for
the
three built-in local laws (linear, elastoplastic, mutation) and the structural law
F2 = k2·x2 − β·x2³ (β = 0: linear). Differences from the reference path, by design:

- each piece is integrated with fixed 8th-order steps (the DOP853 tableau, 8th-order
  solution) of h = ``STEP_RAD`` / ω_max, ω_max bounding the fastest mode of the piece at the
  step's x2; in free flight no longer than the gap needs to possibly close
  (:func:`impactbench.reference.two_dof.gap_step`, floor ``GAP_FLOOR_RAD``), so no contact
  starts and ends within one step; grazes of a law's switch inside a contact are caught by
  the cubic Hermite interpolant of the switch function;
- every event (law switch, contact end, collapse, no further contact) is located by
  safeguarded Newton iteration on the step length, each iterate a fresh 8th-order step from
  the step's start, to |Δt| ≤ 1e-13 s;
- the metrics come from the events directly: peak force = the largest force at a step end,
  an event or a located velocity reversal inside a contact; impulse = m1·(v1(0) − v1(end))
  (body 1 feels F1 only); contact edges are event times.

- at most :data:`MAX_STEPS` steps per impact (then status max_time, ``steps`` saying why);
  the reference path has its own budget.

``tests/reference/test_two_dof.py`` shows it equals ``metrics.compute(simulate(...))``.
Without numba the kernel runs as plain Python (correct, slow).

Speed without changing a bit (``tests/reference/test_two_dof_fast_kernel.py``): the step
is unrolled over the tableau's nonzero entries; no array is allocated per step; the
functions compile with numba's ``error_model="numpy"`` (every division here is guarded or by
a validated positive quantity, so Python's zero-division check was a branch per division
that never fired); and :func:`solve_batch` solves a sweep's chunk in one call, the GIL
released (:func:`run_many`).
"""

from __future__ import annotations

import math

import numpy as np

try:  # numba is an optional accelerator
    from numba import njit
except ImportError:  # pragma: no cover - exercised only without numba
    def njit(*args, **kwargs):  # type: ignore[no-redef]
        if args and callable(args[0]):
            return args[0]
        return lambda f: f

STEP_RAD = 0.1
"""Step length in radians of the fastest mode (h·ω_max)."""
GAP_FLOOR_RAD = 1e-6
"""Shortest free-flight step, in radians of the fastest contact mode (two_dof.GAP_FLOOR_RAD)."""

LOCAL_CODES = {"linear": 0, "elastoplastic": 1, "mutation": 2, "mutation-continuous": 1}
"""Kernel law codes; ``mutation-continuous`` is the elastoplastic kernel with εs = F_m/k1 and
kt = k1' (:class:`impactbench.reference.laws.ContinuousMutation`)."""
STATUS_NAMES = ("ok", "structure_collapsed", "max_time")

# The DOP853 tableau (scipy.integrate._ivp.dop853_coefficients: A[:12, :12] and B, the
# 8th-order solution), its nonzero entries written out: importing scipy.integrate for them
# cost 0.3 s of every sweep's start-up. tests/reference/test_two_dof_fast_kernel.py checks
# them against scipy's, bit for bit.
_A_NONZERO: tuple[tuple[tuple[int, float], ...], ...] = (
    (),
    ((0, 0.05260015195876773),),
    ((0, 0.0197250569845379), (1, 0.0591751709536137)),
    ((0, 0.02958758547680685), (2, 0.08876275643042054)),
    ((0, 0.2413651341592667), (2, -0.8845494793282861), (3, 0.924834003261792)),
    ((0, 0.037037037037037035), (3, 0.17082860872947386), (4, 0.12546768756682242)),
    ((0, 0.037109375), (3, 0.17025221101954405), (4, 0.06021653898045596),
     (5, -0.017578125)),
    ((0, 0.03709200011850479), (3, 0.17038392571223998), (4, 0.10726203044637328),
     (5, -0.015319437748624402), (6, 0.008273789163814023)),
    ((0, 0.6241109587160757), (3, -3.3608926294469414), (4, -0.868219346841726),
     (5, 27.59209969944671), (6, 20.154067550477894), (7, -43.48988418106996)),
    ((0, 0.47766253643826434), (3, -2.4881146199716677), (4, -0.590290826836843),
     (5, 21.230051448181193), (6, 15.279233632882423), (7, -33.28821096898486),
     (8, -0.020331201708508627)),
    ((0, -0.9371424300859873), (3, 5.186372428844064), (4, 1.0914373489967295),
     (5, -8.149787010746927), (6, -18.52006565999696), (7, 22.739487099350505),
     (8, 2.4936055526796523), (9, -3.0467644718982196)),
    ((0, 2.273310147516538), (3, -10.53449546673725), (4, -2.0008720582248625),
     (5, -17.9589318631188), (6, 27.94888452941996), (7, -2.8589982771350235),
     (8, -8.87285693353063), (9, 12.360567175794303), (10, 0.6433927460157636)),
)
_A = np.zeros((12, 12))
for _s, _row in enumerate(_A_NONZERO):
    for _r, _value in _row:
        _A[_s, _r] = _value
del _s, _row, _r, _value
_B = np.array([0.054293734116568765, 0.0, 0.0, 0.0, 0.0, 4.450312892752409,
               1.8915178993145003, -5.801203960010585, 0.3111643669578199,
               -0.1521609496625161, 0.20136540080403034, 0.04471061572777259])

# event kinds
_START, _END, _YIELD, _TURN, _REJOIN, _FAIL, _COLLAPSE, _DONE = range(8)
_MAX_EVENTS = 100_000
MAX_STEPS = 3_000_000
"""Step budget of one impact (steps of ``STEP_RAD`` of the fastest mode: 3e5 rad, ~5e4
periods of it): 1.6–4 s here (measured; 1e7 steps took 11–14 s on 2 shared cores). The
most any test or figure sweep takes is 3.1e5 (measured: the rigid-wall limit k2 = 1e13 N/m;
the crosscheck's random corners ≤ 3e4, the figures' grids less). At m2 = 1e-12 kg (body 2
1e13 times lighter than body 1, its mode √((k1+k2)/m2) 4.5e6 times the contact's √(k1/m1))
one contact needs ~2e8 (ω·T/STEP_RAD; it ran 100 s before this budget): the run stops with
status max_time (``steps`` = MAX_STEPS says why) instead, and at m2 = 1e-30 kg, where it
ran for ever."""


@njit(cache=True, error_model="numpy")
def _rhs(y, k, f0, m1, m2, k2, beta, out):
    dx = y[0] - y[1]
    f1 = k * dx + f0 if k > 0.0 else 0.0
    out[0] = y[2]
    out[1] = y[3]
    out[2] = -f1 / m1
    out[3] = (f1 - (k2 * y[1] - beta * y[1] ** 3)) / m2


@njit(cache=True, error_model="numpy")
def _step(y, h, k, f0, m1, m2, k2, beta, K, tmp, out):
    """One 8th-order Runge–Kutta step of length h from y into out.

    Stage s is y + h·(0 + Σ_r A[s, r]·K[r]) summed in order of r, as a loop over all r < s
    sums it, but over the nonzero A[s, r] only (a zero term adds an exact zero: the same
    bits) and unrolled: a third faster."""
    _rhs(y, k, f0, m1, m2, k2, beta, K[0])
    for j in range(4):
        tmp[j] = y[j] + h * (0.0 + _A[1, 0] * K[0, j])
    _rhs(tmp, k, f0, m1, m2, k2, beta, K[1])
    for j in range(4):
        tmp[j] = y[j] + h * (0.0 + _A[2, 0] * K[0, j] + _A[2, 1] * K[1, j])
    _rhs(tmp, k, f0, m1, m2, k2, beta, K[2])
    for j in range(4):
        tmp[j] = y[j] + h * (0.0 + _A[3, 0] * K[0, j] + _A[3, 2] * K[2, j])
    _rhs(tmp, k, f0, m1, m2, k2, beta, K[3])
    for j in range(4):
        tmp[j] = y[j] + h * (0.0 + _A[4, 0] * K[0, j] + _A[4, 2] * K[2, j] + _A[4, 3] * K[3, j])
    _rhs(tmp, k, f0, m1, m2, k2, beta, K[4])
    for j in range(4):
        tmp[j] = y[j] + h * (0.0 + _A[5, 0] * K[0, j] + _A[5, 3] * K[3, j] + _A[5, 4] * K[4, j])
    _rhs(tmp, k, f0, m1, m2, k2, beta, K[5])
    for j in range(4):
        tmp[j] = y[j] + h * (0.0 + _A[6, 0] * K[0, j] + _A[6, 3] * K[3, j] + _A[6, 4] * K[4, j]
                             + _A[6, 5] * K[5, j])
    _rhs(tmp, k, f0, m1, m2, k2, beta, K[6])
    for j in range(4):
        tmp[j] = y[j] + h * (0.0 + _A[7, 0] * K[0, j] + _A[7, 3] * K[3, j] + _A[7, 4] * K[4, j]
                             + _A[7, 5] * K[5, j] + _A[7, 6] * K[6, j])
    _rhs(tmp, k, f0, m1, m2, k2, beta, K[7])
    for j in range(4):
        tmp[j] = y[j] + h * (0.0 + _A[8, 0] * K[0, j] + _A[8, 3] * K[3, j] + _A[8, 4] * K[4, j]
                             + _A[8, 5] * K[5, j] + _A[8, 6] * K[6, j] + _A[8, 7] * K[7, j])
    _rhs(tmp, k, f0, m1, m2, k2, beta, K[8])
    for j in range(4):
        tmp[j] = y[j] + h * (0.0 + _A[9, 0] * K[0, j] + _A[9, 3] * K[3, j] + _A[9, 4] * K[4, j]
                             + _A[9, 5] * K[5, j] + _A[9, 6] * K[6, j] + _A[9, 7] * K[7, j]
                             + _A[9, 8] * K[8, j])
    _rhs(tmp, k, f0, m1, m2, k2, beta, K[9])
    for j in range(4):
        tmp[j] = y[j] + h * (0.0 + _A[10, 0] * K[0, j] + _A[10, 3] * K[3, j] + _A[10, 4] * K[4, j]
                             + _A[10, 5] * K[5, j] + _A[10, 6] * K[6, j] + _A[10, 7] * K[7, j]
                             + _A[10, 8] * K[8, j] + _A[10, 9] * K[9, j])
    _rhs(tmp, k, f0, m1, m2, k2, beta, K[10])
    for j in range(4):
        tmp[j] = y[j] + h * (0.0 + _A[11, 0] * K[0, j] + _A[11, 3] * K[3, j] + _A[11, 4] * K[4, j]
                             + _A[11, 5] * K[5, j] + _A[11, 6] * K[6, j] + _A[11, 7] * K[7, j]
                             + _A[11, 8] * K[8, j] + _A[11, 9] * K[9, j] + _A[11, 10] * K[10, j])
    _rhs(tmp, k, f0, m1, m2, k2, beta, K[11])
    for j in range(4):
        out[j] = y[j] + h * (0.0 + _B[0] * K[0, j] + _B[5] * K[5, j] + _B[6] * K[6, j]
                            + _B[7] * K[7, j] + _B[8] * K[8, j] + _B[9] * K[9, j]
                            + _B[10] * K[10, j] + _B[11] * K[11, j])


@njit(cache=True, error_model="numpy")
def _piece(code, mode, k1, kt, k1f, eps_s, fm, max_dx, failed, bnd):
    """Stiffness, offset and boundaries (rows: cx, cv, c0, direction, kind, next_mode)."""
    n = 0
    k = 0.0
    f0 = 0.0
    p = 0.0
    if code == 1 and max_dx > eps_s:
        fmax = k1 * eps_s + kt * (max_dx - eps_s)
        p = max_dx - fmax / k1
    if mode == 0:  # free
        nxt = 1
        if code == 1:
            nxt = 1 if max_dx > 0.0 else 2
        elif code == 2:
            nxt = 2 if failed else 1
        bnd[0, 0], bnd[0, 1], bnd[0, 2], bnd[0, 3], bnd[0, 4], bnd[0, 5] = (
            1.0, 0.0, -p, 1.0, _START, nxt)
        n = 1
    elif code == 0:
        k = k1
        bnd[0, 0], bnd[0, 1], bnd[0, 2], bnd[0, 3], bnd[0, 4], bnd[0, 5] = (
            1.0, 0.0, 0.0, -1.0, _END, 0)
        n = 1
    elif code == 1:
        if mode == 1:  # line
            k = k1
            f0 = -k1 * p
            bb = 2 if max_dx < eps_s else 3
            bnd[0, 0], bnd[0, 1], bnd[0, 2], bnd[0, 3], bnd[0, 4], bnd[0, 5] = (
                1.0, 0.0, -p, -1.0, _END, 0)
            bnd[1, 0], bnd[1, 1], bnd[1, 2], bnd[1, 3], bnd[1, 4], bnd[1, 5] = (
                1.0, 0.0, -max_dx, 1.0, _REJOIN, bb)
            n = 2
        elif mode == 2:  # elastic backbone
            k = k1
            bnd[0, 0], bnd[0, 1], bnd[0, 2], bnd[0, 3], bnd[0, 4], bnd[0, 5] = (
                1.0, 0.0, -eps_s, 1.0, _YIELD, 3)
            bnd[1, 0], bnd[1, 1], bnd[1, 2], bnd[1, 3], bnd[1, 4], bnd[1, 5] = (
                0.0, 1.0, 0.0, -1.0, _TURN, 1)
            n = 2
        else:  # plastic backbone
            k = kt
            f0 = (k1 - kt) * eps_s
            bnd[0, 0], bnd[0, 1], bnd[0, 2], bnd[0, 3], bnd[0, 4], bnd[0, 5] = (
                0.0, 1.0, 0.0, -1.0, _TURN, 1)
            n = 1
    else:
        if mode == 1:  # intact
            k = k1
            bnd[0, 0], bnd[0, 1], bnd[0, 2], bnd[0, 3], bnd[0, 4], bnd[0, 5] = (
                1.0, 0.0, 0.0, -1.0, _END, 0)
            bnd[1, 0], bnd[1, 1], bnd[1, 2], bnd[1, 3], bnd[1, 4], bnd[1, 5] = (
                1.0, 0.0, -fm / k1, 1.0, _FAIL, 2)
            n = 2
        else:  # failed
            k = k1f
            bnd[0, 0], bnd[0, 1], bnd[0, 2], bnd[0, 3], bnd[0, 4], bnd[0, 5] = (
                1.0, 0.0, 0.0, -1.0, _END, 0)
            n = 1
    return k, f0, n, p


@njit(cache=True, error_model="numpy")
def _reach(e, k2, beta):
    e = max(e, 0.0)
    if beta == 0.0:
        return math.sqrt(2.0 * e / k2)
    disc = k2 * k2 - 4.0 * beta * e
    if disc <= 0.0:
        return math.inf
    return math.sqrt(4.0 * e / (k2 + math.sqrt(disc)))


@njit(cache=True, error_model="numpy")
def _max_force(r, k2, beta):
    """Largest F2 (N) over 0 ≤ x2 ≤ r (laws.StructuralLaw.max_force)."""
    if beta > 0.0:
        r = min(r, math.sqrt(k2 / (3.0 * beta)))
    return k2 * r - beta * r ** 3


@njit(cache=True, error_model="numpy")
def _gap_step(gap, rate, accel):
    """Time before a free gap can reach zero (two_dof.gap_step)."""
    g = -min(gap, 0.0)
    if accel <= 0.0:
        return g / rate if rate > 0.0 else math.inf
    root = math.sqrt(rate * rate + 2.0 * accel * g)
    return (root - rate) / accel if rate <= 0.0 else 2.0 * g / (rate + root)


@njit(cache=True, error_model="numpy")
def _g(kind, row, y, m2, k2, beta, ec, reach_p, k, f0, out_dg):
    """Event function value; its time derivative into out_dg[0]."""
    if kind == 0:  # a law boundary, linear in (Δx, Δẋ)
        return 0.0
    if kind == 1:  # collapse: E2 − k2²/(4β)
        dx = y[0] - y[1]
        f1 = k * dx + f0
        out_dg[0] = f1 * y[3]
        return 0.5 * m2 * y[3] ** 2 + 0.5 * k2 * y[1] ** 2 - 0.25 * beta * y[1] ** 4 - ec
    if reach_p < math.inf:  # done (bounded): x1 − p + reach
        out_dg[0] = y[2]
        return y[0] + reach_p
    # done (escaped, free flight): min(x2 − x_c, v2 − max(v1, 0))
    out_dg[0] = 0.0
    if beta <= 0.0:  # never escapes (the event is not armed)
        return -1.0
    a = y[1] - math.sqrt(k2 / beta)
    b = y[3] - max(y[2], 0.0)
    if a <= b:
        out_dg[0] = y[3]
        return a
    out_dg[0] = -(k2 * y[1] - beta * y[1] ** 3) / m2
    return b


@njit(cache=True, error_model="numpy")
def _ev(which, nb, bnd, y, ydot, m2, k2, beta, ec, reach_p, k, f0, dg):
    """Value and derivative of event ``which`` (< nb: boundary; nb: collapse; nb+1: done;
    nb+2: velocity reversal, the peak)."""
    if which < nb:
        dg[0] = bnd[which, 0] * (ydot[0] - ydot[1]) + bnd[which, 1] * (ydot[2] - ydot[3])
        return bnd[which, 0] * (y[0] - y[1]) + bnd[which, 1] * (y[2] - y[3]) + bnd[which, 2]
    if which == nb:
        return _g(1, 0, y, m2, k2, beta, ec, reach_p, k, f0, dg)
    if which == nb + 1:
        return _g(2, 0, y, m2, k2, beta, ec, reach_p, k, f0, dg)
    dg[0] = ydot[2] - ydot[3]
    return y[2] - y[3]


@njit(cache=True, error_model="numpy")
def _locate(which, nb, bnd, y0, h, ga, gb, k, f0, m1, m2, k2, beta, ec, reach_p,
            K, tmp, ys, ydot, dg):
    """Step length s in (0, h] where event ``which`` crosses zero (safeguarded Newton)."""
    a, b = 0.0, h
    s = h * ga / (ga - gb)
    for _ in range(60):
        if not (a < s < b):
            s = 0.5 * (a + b)
        _step(y0, s, k, f0, m1, m2, k2, beta, K, tmp, ys)
        _rhs(ys, k, f0, m1, m2, k2, beta, ydot)
        g = _ev(which, nb, bnd, ys, ydot, m2, k2, beta, ec, reach_p, k, f0, dg)
        if g == 0.0:
            return s
        if (g > 0.0) == (ga > 0.0):
            a = s
        else:
            b = s
        snew = s - g / dg[0] if dg[0] != 0.0 else 0.5 * (a + b)
        if abs(snew - s) <= 1e-13 or b - a <= 1e-13:
            if a < snew < b:
                return snew
            return b
        s = snew
    return b


@njit(cache=True, error_model="numpy")
def _hermite_extremum(g0, d0, g1, d1, h):
    """Step fraction s in (0, h) of an interior extremum of the cubic Hermite interpolant of g
    (values g0, g1 and slopes d0, d1 at 0 and h) where it reaches the other sign; −1 if none."""
    # g(τ) = g0 + d0·h·τ + c2·τ² + c3·τ³ on τ ∈ [0, 1]
    c2 = 3.0 * (g1 - g0) - h * (2.0 * d0 + d1)
    c3 = 2.0 * (g0 - g1) + h * (d0 + d1)
    a, b, c = 3.0 * c3, 2.0 * c2, d0 * h
    r0 = -1.0  # the (at most two) roots, in scalars: no array allocated per call
    r1 = -1.0
    n = 0
    if abs(a) < 1e-300:
        if b != 0.0:
            r0 = -c / b
            n = 1
    else:
        disc = b * b - 4.0 * a * c
        if disc >= 0.0:
            q = -0.5 * (b + math.copysign(math.sqrt(disc), b))
            r0 = q / a
            r1 = c / q if q != 0.0 else -1.0
            n = 2
    best = -1.0
    for i in range(n):
        tau = r0 if i == 0 else r1
        if 0.0 < tau < 1.0:
            gv = g0 + (d0 * h + (c2 + c3 * tau) * tau) * tau
            if (gv >= 0.0) != (g0 >= 0.0) and (best < 0.0 or tau * h < best):
                best = tau * h
    return best


@njit(cache=True, error_model="numpy")
def _free_piece(y, p, m2, k2, beta, xc):
    """Out of contact (y = x1, x2, v1, v2; p the permanent set): (over: no further contact
    possible, use_done: watch the end event, its direction, the gap x1 − x2 at which it
    fires, body 2's largest acceleration m2⁻¹·max|F2| within its reach)."""
    e2 = 0.5 * m2 * y[3] ** 2 + 0.5 * k2 * y[1] ** 2 - 0.25 * beta * y[1] ** 4
    r = _reach(e2, k2, beta)
    accel = _max_force(r, k2, beta) / m2
    over = (y[2] <= 0.0 and y[0] - p < -r) or (y[1] > xc and y[3] >= max(y[2], 0.0))
    if y[2] < 0.0 and r < math.inf:
        return over, True, -1.0, r - p, accel
    if r == math.inf:  # escaped: x2 past x_c and v2 ≥ max(v1, 0)
        return over, True, 1.0, math.inf, accel
    return over, False, -1.0, math.inf, accel


@njit(cache=True, error_model="numpy")
def _switched(kind, code, t, dx, impacts, contact_start, contact_time, last_end, max_dx,
              failed):
    """The bookkeeping of a switch of kind ``kind`` at time t (s) and compression dx (m):
    (impacts, contact_start, contact_time, last_end, max_dx, failed), updated."""
    if kind == _START:
        impacts += 1
        contact_start = t
    elif kind == _END:
        contact_time += t - contact_start
        last_end = t
    if kind == _TURN or code == 1:
        max_dx = max(max_dx, dx)
    return impacts, contact_start, contact_time, last_end, max_dx, failed or kind == _FAIL


# One function on purpose (ruff's mccabe: 43): splitting its per-step event scan into its
# own compiled function, even numba-inlined, made 200 random impacts 1.41–1.57× slower
# (medians of 7 alternated rounds), and this is the 2-DOF sweeps' hot path.
@njit(cache=True, error_model="numpy", nogil=True)
def solve_kernel(code, v0, m1, m2, k1, k2, kt, k1f, eps_s, beta, fm, tmax, step_rad):
    """One impact. Returns (status 0 ok / 1 collapsed / 2 max_time, peak_force_n,
    pulse_width_s, contact_time_s, impulse_ns, impacts, t_end, x1, x2, v1, v2, max_dx,
    failed, steps); ``steps`` ≥ :data:`MAX_STEPS`: the step budget ran out (status 2)."""
    y = np.zeros(4)
    y[2] = v0
    ynew = np.zeros(4)
    ys = np.zeros(4)
    ydot = np.zeros(4)
    dg = np.zeros(1)
    dg2 = np.zeros(1)
    ydot2 = np.zeros(4)
    K = np.zeros((12, 4))
    tmp = np.zeros(4)
    bnd = np.zeros((2, 6))
    ev = np.zeros((4, 5))  # per piece: gold, gnew, dgold, dgnew (nev = nb + 3 <= 5)
    # per piece and event: the direction of the crossing it waits for (+1 up, −1 down; 0:
    # not watched in this piece)
    direction = np.zeros(5)
    ec = k2 * k2 / (4.0 * beta) if beta > 0.0 else math.inf
    xc = math.sqrt(k2 / beta) if beta > 0.0 else math.inf
    kmax = max(k1, kt, k1f)
    h_floor = GAP_FLOOR_RAD / math.sqrt(kmax / m1 + (kmax + k2) / m2)
    collapsed = False
    t = 0.0
    max_dx = 0.0
    failed = False
    peak = 0.0
    contact_time = 0.0
    last_end = 0.0
    contact_start = 0.0
    impacts = 1
    status = 2
    steps = 0
    # the first contact starts at t = 0
    mode = 2 if code == 1 else 1
    for _ in range(_MAX_EVENTS):
        k, f0, nb, p = _piece(code, mode, k1, kt, k1f, eps_s, fm, max_dx, failed, bnd)
        contact = k > 0.0
        reach_p = math.inf
        use_done = False
        done_dir = -1.0
        accel = 0.0
        if not contact:
            over, use_done, done_dir, reach_p, accel = _free_piece(y, p, m2, k2, beta, xc)
            if over:
                status = 0
                break
        use_collapse = contact and ec < math.inf and not collapsed
        use_peak = contact and not (code == 1 and mode >= 2)
        nev = nb + 3
        # event values at the start of the piece
        ev[:, :] = 0.0
        gold = ev[0]
        gnew = ev[1]
        dgold = ev[2]
        dgnew = ev[3]
        direction[:nb] = bnd[:nb, 3]
        direction[nb] = 1.0 if use_collapse else 0.0
        direction[nb + 1] = done_dir if use_done else 0.0
        direction[nb + 2] = -1.0 if use_peak else 0.0
        _rhs(y, k, f0, m1, m2, k2, beta, ydot)
        for w in range(nev):
            gold[w] = _ev(w, nb, bnd, y, ydot, m2, k2, beta, ec, reach_p, k, f0, dg)
            dgold[w] = dg[0]
        found = -1
        s_found = 0.0
        while steps < MAX_STEPS:
            steps += 1
            s_peak = -1.0
            f_peak = 0.0
            # the step: a fraction of the fastest period (a softening structure's tangent
            # stiffness |k2 − 3β·x2²| counts past √(2k2/(3β))); out of contact, also no
            # longer than the gap needs to possibly close (_gap_step), so no contact can
            # start and end within one step
            ks = max(k2, abs(k2 - 3.0 * beta * y[1] * y[1]))
            h = step_rad / math.sqrt(k / m1 + (k + ks) / m2)
            if not contact:
                h = min(h, max(_gap_step(y[0] - y[1] - p, y[2] - y[3], accel), h_floor))
            last = False
            if t + h >= tmax:
                h = tmax - t
                last = True
            _step(y, h, k, f0, m1, m2, k2, beta, K, tmp, ynew)
            _rhs(ynew, k, f0, m1, m2, k2, beta, ydot)
            best = h + 1.0
            for w in range(nev):
                d = direction[w]
                if d == 0.0:
                    continue
                gnew[w] = _ev(w, nb, bnd, ynew, ydot, m2, k2, beta, ec, reach_p, k, f0, dg)
                dgnew[w] = dg[0]
                # crossing in direction d (±1): from d·g < 0 to d·g ≥ 0
                hit = d * gold[w] < 0.0 and d * gnew[w] >= 0.0
                hb = h
                gb = gnew[w]
                if not hit and w < nb and d * gold[w] < 0.0 and d * gnew[w] < 0.0:
                    # a crossing and return inside the step (a graze): the cubic Hermite
                    # interpolant of g (g' known at both ends) peaks on the far side?
                    sm = _hermite_extremum(gold[w], dgold[w], gnew[w], dg[0], h)
                    if sm > 0.0:
                        _step(y, sm, k, f0, m1, m2, k2, beta, K, tmp, ys)
                        _rhs(ys, k, f0, m1, m2, k2, beta, ydot2)
                        gm = _ev(w, nb, bnd, ys, ydot2, m2, k2, beta, ec, reach_p, k, f0, dg2)
                        hit = d * gm >= 0.0
                        hb = sm if hit else h
                        gb = gm if hit else gb
                if hit:
                    s = _locate(w, nb, bnd, y, hb, gold[w], gb, k, f0, m1, m2, k2, beta,
                                ec, reach_p, K, tmp, ys, ydot2, dg2)
                    if w == nb + 2:  # velocity reversal: a force maximum, not a switch
                        _step(y, s, k, f0, m1, m2, k2, beta, K, tmp, ys)
                        s_peak = s
                        f_peak = k * (ys[0] - ys[1]) + f0
                        continue
                    if s < best:
                        best = s
                        found = w
            if s_peak >= 0.0 and (found < 0 or s_peak <= best) and f_peak > peak:
                peak = f_peak
            if found >= 0:
                s_found = best
                break
            for j in range(4):
                y[j] = ynew[j]
            for w in range(nev):
                gold[w] = gnew[w]
                dgold[w] = dgnew[w]
            t += h
            if contact:
                fn = k * (y[0] - y[1]) + f0
                if fn > peak:
                    peak = fn
            if last:
                break
        if found < 0:  # time cap or step budget
            status = 2
            break
        _step(y, s_found, k, f0, m1, m2, k2, beta, K, tmp, ynew)
        for j in range(4):
            y[j] = ynew[j]
        t += s_found
        dx = y[0] - y[1]
        if contact:
            fn = k * dx + f0
            if fn > peak:
                peak = fn
        if found == nb:  # collapse: flagged; the run goes on until body 2 escapes
            collapsed = True
            continue
        if found == nb + 1:
            status = 0
            break
        impacts, contact_start, contact_time, last_end, max_dx, failed = _switched(
            int(bnd[found, 4]), code, t, dx, impacts, contact_start, contact_time, last_end,
            max_dx, failed)
        mode = int(bnd[found, 5])
    if collapsed and status == 0:
        status = 1
    in_contact = mode != 0
    if in_contact:
        contact_time += t - contact_start
        last_end = t
    impulse = m1 * (v0 - y[2])
    return (status, peak, last_end, contact_time, impulse, impacts, t, y[0], y[1], y[2], y[3],
            max_dx, 1.0 if failed else 0.0, steps)


PARAMS: tuple[str, ...] = ("velocity_m_s", "m1_kg", "m2_kg", "k1_n_per_m", "k2_n_per_m", "kt",
                           "k1_failed_n_per_m", "eps_s", "beta", "fm_n", "max_time_s")
"""The kernel's per-impact inputs after the law code, in order (``kt`` and ``eps_s`` as the
kernel reads them: k1' and F_m/k1 for ``mutation-continuous``; ``beta`` 0 for a linear
structure)."""
RESULTS: tuple[str, ...] = ("status", "peak_force_n", "pulse_width_s", "contact_time_s",
                            "impulse_ns", "impacts", "t_end_s", "x1_m", "x2_m", "v1_m_s",
                            "v2_m_s", "max_dx_m", "failed", "steps")
"""The kernel's results, in order (:func:`solve_kernel`)."""


@njit(cache=True, error_model="numpy", nogil=True)
def solve_batch(code, params, step_rad, out):
    """:func:`solve_kernel` for every row of ``params`` (n, 11: :data:`PARAMS`) with law
    ``code``, its results into the rows of ``out`` (n, 14: :data:`RESULTS`, the integers as
    floats): one call for a whole chunk of a sweep, the same numbers bit for bit. Releases
    the GIL: chunks solve on several threads at once."""
    for i in range(params.shape[0]):
        p = params[i]
        r = solve_kernel(code, p[0], p[1], p[2], p[3], p[4], p[5], p[6], p[7], p[8], p[9],
                         p[10], step_rad)
        (out[i, 0], out[i, 1], out[i, 2], out[i, 3], out[i, 4], out[i, 5], out[i, 6],
         out[i, 7], out[i, 8], out[i, 9], out[i, 10], out[i, 11], out[i, 12], out[i, 13]) = r


def kernel_params(scenario) -> tuple[int, tuple[float, ...]]:
    """(law code, :data:`PARAMS`) of a RigidFlexible scenario with a built-in local law."""
    sc = scenario
    beta = sc.beta_n_per_m3 if sc.structure == "softening" else 0.0
    kt, eps_s = sc.kt_n_per_m, sc.eps_s_m
    if sc.local == "mutation-continuous":
        kt, eps_s = sc.k1_failed_n_per_m, sc.fm_n / sc.k1_n_per_m
    return LOCAL_CODES[sc.local], (sc.velocity_m_s, sc.m1_kg, sc.m2_kg, sc.k1_n_per_m,
                                   sc.k2_n_per_m, kt, sc.k1_failed_n_per_m, eps_s, beta,
                                   sc.fm_n, sc.max_time_s)


def run(scenario, step_rad: float = STEP_RAD) -> tuple:
    """The kernel's raw tuple for a RigidFlexible scenario with a built-in local law."""
    code, p = kernel_params(scenario)
    return solve_kernel(code, *p, step_rad)


def run_many(code: int, params: np.ndarray, step_rad: float = STEP_RAD) -> np.ndarray:
    """The kernel's results (n, 14: :data:`RESULTS`) for ``params`` (n, 11: :data:`PARAMS`)
    under law ``code``, in one compiled loop (:func:`solve_batch`)."""
    p = np.ascontiguousarray(params, dtype=float).reshape(-1, len(PARAMS))
    out = np.empty((p.shape[0], len(RESULTS)))
    solve_batch(int(code), p, float(step_rad), out)
    return out
