"""A rigid box with compliant corner contacts on a flat board, integrated accurately (scipy).

The cube-toss scenario's model floor (MODELS.md §4): how close a continuous contact model gets
to the measured tosses. Units SI throughout; the board's frame has z up (the board's normal)
and gravity g = 9.81 m/s² along −z.

**Body.** A box of half width h (m), mass m (kg) and principal moments of inertia I (kg·m²;
one value for a cube, or three), its centre of mass at its centre. State (13 numbers)::

    y = (p, q, v, ω)

p (m): the centre in the board's frame; q = (w, x, y, z): the unit quaternion of the rotation
body → board, R(q), w first (the cube-toss data's convention); v (m/s): the centre's velocity
in the board's frame; ω (rad/s): the angular velocity **in the body frame** (the data's
convention, and Euler's equations are simplest there).

**Contacts.** Only the eight corners touch the board (a box on a plane touches it first and
last with corners; an edge or a face is two or four corners). Corner i sits at r_i = R·(±h,
±h, ±h) from the centre; its penetration below the board's surface z_b is x_i = z_b − (p_z +
r_i,z) and its velocity u_i = v + (R·ω) × r_i, so ẋ_i = −u_i,z. Per corner in contact (x_i > 0):

- normal force F_n,i ≥ 0 (N) along +z from a law of the zoo (:data:`LAWS`):
  ``hunt-crossley``: F_n = c·xⁿ·(1 + b·ẋ), clipped at 0 (Hunt & Crossley 1975; the zoo's
  :class:`~impactbench.reference.laws.HuntCrossley`, c in N/mⁿ, b in s/m);
  ``kelvin-voigt-clipped``: F_n = max(0, k·x + d·ẋ) (the zoo's
  :class:`~impactbench.reference.models.KelvinVoigt` with ``clipped=True``, k in N/m, d in
  N·s/m; ``exponent`` must be 1);
- friction in the board's plane, a regularised Coulomb law (the √ form, not tanh)::

      F_t,i = −μ·F_n,i · u_t,i / √(|u_t,i|² + v_s²),

  u_t,i the corner's tangential (x, y) velocity, v_s (m/s) the regularisation velocity: for
  |u_t| ≫ v_s it is Coulomb's sliding friction −μ·F_n·û_t, below v_s a stiff viscous law
  (creep instead of stick). The role and name of v_s are those of the "stiction tolerance" of
  compliant-contact simulators (Drake's continuous MultibodyPlant regularises Coulomb friction
  with it, with a different smooth curve; DAIR's Drake replays of these tosses ran such a
  model).

**Equations** (Newton–Euler; the board is fixed)::

    ṗ = v,   m·v̇ = Σ F_i − m·g·e_z,
    q̇ = ½ q ⊗ (0, ω),
    I·ω̇ = Rᵀ·Σ (r_i × F_i) − ω × (I·ω)   (the gyroscopic term; zero for a cube),

with F_i = (F_t,i, F_n,i). The quaternion is renormalised wherever it is used (R(q/|q|), and
every pose returned); the integrator's error control keeps |q| within its tolerance of 1.

**Integration.** :func:`scipy.integrate.solve_ivp` with ``LSODA`` (Petzold 1983; ODEPACK,
Hindmarsh 1983) by default: the flights are non-stiff (Adams steps) and the contacts turn
stiff once the box rests on the board — the corners' springs and, above all, the friction
regularisation below v_s, a viscous law of coefficient μ·F_n/v_s whose time constant
m·v_s/(μ·F_n) falls below a millisecond — and there LSODA switches to BDF with a
finite-difference Jacobian. Measured on the 89 test tosses with the fitted parameters (one
core): LSODA 2.2–3.8 s, ``RK45`` 1.6×, ``DOP853`` 2.5–2.8× as long (explicit methods pay for
the resting phases), ``Radau`` and ``BDF`` 3–6× on a sample; ``method`` takes any of them.
Tolerances :data:`RTOL` and :data:`ATOL` (per component: 1e-9 m, 1e-9 for q, 1e-7 m/s,
1e-6 rad/s) and :data:`MAX_STEP_S` converge the replays: halving the tolerances changes a
toss's time-mean position error by ≤ 1.2e-5 of the width (median 5e-7) and its rotation error
by ≤ 0.003°, at least 8 000 times less than that toss's model-vs-data error (≥ 0.036 widths,
≥ 2.7°); DOP853 and RK45 agree with LSODA to 3e-5 widths. The right-hand side
(:meth:`BoxOnBoard.rhs`) sums over the corners in plain Python floats, with a shortcut for
free flight: ~4 µs a call against ~35 µs for the same sums as numpy arrays of 8 corners
(:meth:`BoxOnBoard.contact_forces`, kept as its cross-check), and the right-hand side is most
of a replay's time.

Sources: K. H. Hunt, F. R. E. Crossley, "Coefficient of restitution interpreted as damping in
vibroimpact", J. Appl. Mech. 42(2):440–445, 1975; Newton–Euler equations of a rigid body and
quaternion kinematics: e.g. R. Featherstone, *Rigid Body Dynamics Algorithms*, Springer 2008,
and J. Diebel, "Representing attitude: Euler angles, unit quaternions, and rotation vectors",
2006; the regularised Coulomb law with a stiction tolerance: Drake's documentation of
MultibodyPlant's continuous contact ("Modeling of Dry Friction"), A. M. Castro et al., "A
transition-aware method for the simulation of compliant contact with regularized friction",
IEEE RA-L 5(2):1859–1866, 2020; LSODA: L. R. Petzold, SIAM J. Sci. Stat. Comput. 4(1):136–148,
1983. The tosses and the box's m, I and h: Acosta, Yang & Posa, IEEE RA-L 2022 (DAIR Lab).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import asdict, dataclass

import numpy as np
from impactbench.reference import validation as check
from impactbench.reference.laws import HuntCrossley
from impactbench.reference.models import KelvinVoigt
from scipy import integrate

LAWS: tuple[str, ...] = ("hunt-crossley", "kelvin-voigt-clipped")
"""The normal laws a corner may have (module doc)."""
GRAVITY_M_S2 = 9.81
HALF_WIDTH_M = 0.0524
MASS_KG = 0.37
INERTIA_KG_M2 = 0.00081
"""DAIR's cube (``cube.urdf``): h, m and I about each principal axis."""

METHOD = "LSODA"
RTOL = 1e-7
"""Relative tolerance of the integration (module doc)."""
ATOL = np.array([1e-9] * 3 + [1e-9] * 4 + [1e-7] * 3 + [1e-6] * 3)
"""Absolute tolerances of (p, q, v, ω): m, 1, m/s, rad/s (module doc)."""
MAX_STEP_S = 1e-3
"""The longest step (s): a fraction of any corner's contact (the fitted law's one-corner impact
lasts 9–32 ms from 0.1 to 3 m/s with effective masses m/4 to 3m), so no step jumps over a whole
bounce whatever the parameters; it costs nothing measurable (without it the 89 test replays
change by ≤ 3e-5 widths and take longer)."""
MAX_EVALUATIONS = 500_000
"""Right-hand-side evaluations after which an integration gives up (a candidate of a fit
that would take minutes; a toss takes ~10⁴)."""


class IntegrationBudgetExceeded(RuntimeError):
    """The integration needed more than its ``max_evaluations``."""


@dataclass(frozen=True)
class Box:
    """The box: half width h (m), mass (kg), principal moments of inertia (kg·m²: one number
    for a cube, or three for a box with three different moments)."""

    half_width_m: float = HALF_WIDTH_M
    mass_kg: float = MASS_KG
    inertia_kg_m2: float | tuple[float, float, float] = INERTIA_KG_M2

    def __post_init__(self) -> None:
        check.positive("half_width_m", self.half_width_m)
        check.positive("mass_kg", self.mass_kg)
        if isinstance(self.inertia_kg_m2, Sequence) and not isinstance(self.inertia_kg_m2, str):
            if len(self.inertia_kg_m2) != 3:
                raise ValueError(f"inertia_kg_m2 = {self.inertia_kg_m2!r}: must be one number "
                                 "or three (the principal moments)")
            for i, v in enumerate(self.inertia_kg_m2):
                check.positive(f"inertia_kg_m2[{i}]", v)
            a, b, c = sorted(float(v) for v in self.inertia_kg_m2)
            if a + b < c * (1.0 - 1e-12):
                raise ValueError(f"inertia_kg_m2 = {self.inertia_kg_m2!r}: must satisfy the "
                                 "triangle inequality (no moment larger than the other two's "
                                 "sum)")
        else:
            check.positive("inertia_kg_m2", self.inertia_kg_m2)

    @property
    def inertia(self) -> np.ndarray:
        """The three principal moments (kg·m²)."""
        return np.broadcast_to(np.asarray(self.inertia_kg_m2, dtype=float), (3,)).copy()

    @property
    def corners(self) -> np.ndarray:
        """The eight corners in the body frame (m), shape (8, 3)."""
        s = np.array([[i, j, k] for i in (-1, 1) for j in (-1, 1) for k in (-1, 1)], float)
        return self.half_width_m * s


DAIR_CUBE = Box()
"""DAIR's cube (the default box)."""


@dataclass(frozen=True)
class BoxContactParams:
    """The contact model's parameters (per corner; module doc).

    Attributes:
        law: the normal law, one of :data:`LAWS`.
        stiffness: c of c·xⁿ (N/mⁿ; N/m for ``kelvin-voigt-clipped``).
        exponent: n (1 for ``kelvin-voigt-clipped``; Hunt–Crossley: any n in [1, 3]).
        damping: b (s/m) of Hunt–Crossley's (1 + b·ẋ); d (N·s/m) of Kelvin–Voigt's d·ẋ.
        friction: Coulomb's μ (≥ 0).
        slip_velocity_m_s: the regularisation velocity v_s (m/s, > 0).
    """

    law: str = "hunt-crossley"
    stiffness: float = 1e5
    exponent: float = 1.5
    damping: float = 1.0
    friction: float = 0.3
    slip_velocity_m_s: float = 1e-3

    def __post_init__(self) -> None:
        check.one_of("law", self.law, LAWS)
        check.positive("stiffness", self.stiffness)
        n = check.positive("exponent", self.exponent)
        if self.law == "kelvin-voigt-clipped" and n != 1.0:
            raise ValueError(f"exponent = {self.exponent!r}: must be 1 for law "
                             "'kelvin-voigt-clipped'")
        if not 1.0 <= n <= 3.0:
            raise ValueError(f"exponent = {self.exponent!r}: must be in [1, 3]")
        check.non_negative("damping", self.damping)
        check.non_negative("friction", self.friction)
        check.positive("slip_velocity_m_s", self.slip_velocity_m_s)

    def corner_law(self) -> HuntCrossley | KelvinVoigt:
        """One corner's normal law as the zoo's object (its ``force(x, ẋ)`` is the law used
        here; the tests compare restitutions with the zoo's closed forms)."""
        if self.law == "kelvin-voigt-clipped":
            return KelvinVoigt(self.stiffness, self.damping, clipped=True)
        return HuntCrossley(self.stiffness, self.exponent, self.damping)

    def describe(self) -> dict[str, float | str]:
        return asdict(self)


# ------------------------------------------------------------------------------ quaternions


def quat_matrix(q: np.ndarray) -> np.ndarray:
    """Rotation matrix R (body → board) of the quaternion ``q`` (w, x, y, z; normalised
    here)."""
    # the entries in Python floats: the same IEEE operations as on numpy's scalars, without
    # their overhead; |q|² stays numpy's dot (BLAS: its summation order is the library's)
    s = math.sqrt(float(np.dot(q, q)))
    w, x, y, z = (v / s for v in np.asarray(q, dtype=float).tolist())
    return _matrix(w, x, y, z)


def _matrix(w: float, x: float, y: float, z: float) -> np.ndarray:
    """R of the unit quaternion (w, x, y, z) as a C-ordered 3 × 3 array (:func:`quat_matrix`'s
    entries)."""
    return np.array([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y),
                     2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x),
                     2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]
                    ).reshape(3, 3)


def quat_multiply(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The Hamilton product a ⊗ b of quaternions (w, x, y, z; last axis)."""
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    aw, av = a[..., :1], a[..., 1:]
    bw, bv = b[..., :1], b[..., 1:]
    return np.concatenate([aw * bw - np.sum(av * bv, axis=-1, keepdims=True),
                           aw * bv + bw * av + np.cross(av, bv)], axis=-1)


# ------------------------------------------------------------------------------ the model

_SIGNS = tuple((i, j, k) for i in (-1.0, 1.0) for j in (-1.0, 1.0) for k in (-1.0, 1.0))
"""The corners' signs, in :attr:`Box.corners`' order."""


class BoxOnBoard:
    """The equations of one box with one parameter set on a board at height ``board_z_m``
    (m); :meth:`rhs` is the right-hand side dy/dt of the 13-number state (module doc)."""

    def __init__(self, params: BoxContactParams, box: Box = Box(), *,
                 board_z_m: float = 0.0, gravity_m_s2: float = GRAVITY_M_S2) -> None:
        if not isinstance(params, BoxContactParams):
            raise ValueError(f"params = {params!r}: must be a BoxContactParams")
        if not isinstance(box, Box):
            raise ValueError(f"box = {box!r}: must be a Box")
        self.params, self.box = params, box
        self.board_z = check.finite("board_z_m", board_z_m)
        self.g = check.non_negative("gravity_m_s2", gravity_m_s2)
        self.m = box.mass_kg
        self.inertia = box.inertia
        self._inertia = tuple(float(i) for i in self.inertia)
        self.corners = box.corners
        self.h = box.half_width_m
        self.reach = box.half_width_m * math.sqrt(3.0)
        self.linear = params.law == "kelvin-voigt-clipped"
        self.c, self.n, self.b = params.stiffness, params.exponent, params.damping
        self.mu, self.vs2 = params.friction, params.slip_velocity_m_s ** 2
        self.evaluations = 0
        self.max_evaluations = MAX_EVALUATIONS

    def normal_force(self, x: np.ndarray, rate: np.ndarray) -> np.ndarray:
        """F_n (N) of corners at penetrations ``x`` > 0 (m) and rates ``rate`` (m/s)."""
        if self.linear:
            f = self.c * x + self.b * rate
        elif self.n == 1.0:
            f = self.c * x * (1.0 + self.b * rate)
        else:
            f = self.c * x ** self.n * (1.0 + self.b * rate)
        return np.maximum(f, 0.0)

    def contact_forces(self, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(r, F): the lever arms (m, board frame) and forces (N) of the corners in contact,
        shapes (k, 3)."""
        q = y[3:7]
        w, x, yq, z = q / math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
        rot = np.array([
            [1 - 2 * (yq * yq + z * z), 2 * (x * yq - w * z), 2 * (x * z + w * yq)],
            [2 * (x * yq + w * z), 1 - 2 * (x * x + z * z), 2 * (yq * z - w * x)],
            [2 * (x * z - w * yq), 2 * (yq * z + w * x), 1 - 2 * (x * x + yq * yq)]])
        r = self.corners @ rot.T
        pen = self.board_z - y[2] - r[:, 2]
        touching = pen > 0.0
        if not touching.any():
            return r[:0], r[:0]
        r = r[touching]
        pen = pen[touching]
        om = rot @ y[10:13]
        # u = v + ω × r, per corner
        ux = y[7] + om[1] * r[:, 2] - om[2] * r[:, 1]
        uy = y[8] + om[2] * r[:, 0] - om[0] * r[:, 2]
        uz = y[9] + om[0] * r[:, 1] - om[1] * r[:, 0]
        fn = self.normal_force(pen, -uz)
        scale = -self.mu * fn / np.sqrt(ux * ux + uy * uy + self.vs2)
        return r, np.column_stack([scale * ux, scale * uy, fn])

    def rhs(self, _t: float, y: np.ndarray) -> np.ndarray:
        """dy/dt (module doc). Plain-Python scalars over the corners: for 8 corners this is
        ~9× faster than the same sums as numpy arrays (:meth:`contact_forces`; measured 4 µs
        against 35 µs per call), which is most of a replay's time."""
        self.evaluations += 1
        if self.evaluations > self.max_evaluations:
            raise IntegrationBudgetExceeded(f"more than {self.max_evaluations} evaluations")
        _px, _py, pz, q0, q1, q2, q3, vx, vy, vz, wx, wy, wz = y.tolist()
        nq = 1.0 / math.sqrt(q0 * q0 + q1 * q1 + q2 * q2 + q3 * q3)
        q0, q1, q2, q3 = q0 * nq, q1 * nq, q2 * nq, q3 * nq
        # q̇ = ½ q ⊗ (0, ω)
        dq0 = 0.5 * (-q1 * wx - q2 * wy - q3 * wz)
        dq1 = 0.5 * (q0 * wx + q2 * wz - q3 * wy)
        dq2 = 0.5 * (q0 * wy + q3 * wx - q1 * wz)
        dq3 = 0.5 * (q0 * wz + q1 * wy - q2 * wx)
        ia, ib, ic = self._inertia
        # −ω × (I·ω), body frame
        gx, gy, gz = (ib - ic) * wy * wz, (ic - ia) * wz * wx, (ia - ib) * wx * wy
        free = [vx, vy, vz, dq0, dq1, dq2, dq3, 0.0, 0.0, -self.g, gx / ia, gy / ib, gz / ic]
        if pz - self.reach >= self.board_z:        # no corner can reach the board
            return np.array(free)
        h, c, n, b, mu, vs2 = self.h, self.c, self.n, self.b, self.mu, self.vs2
        r20 = 2 * (q1 * q3 - q0 * q2)
        r21 = 2 * (q2 * q3 + q0 * q1)
        r22 = 1 - 2 * (q1 * q1 + q2 * q2)
        depth = self.board_z - pz
        fx = fy = fz = tx = ty = tz = 0.0
        touching = False
        for s0, s1, s2 in _SIGNS:
            rz = h * (s0 * r20 + s1 * r21 + s2 * r22)
            pen = depth - rz
            if pen <= 0.0:
                continue
            if not touching:
                touching = True
                r00, r01, r02 = 1 - 2 * (q2 * q2 + q3 * q3), 2 * (q1 * q2 - q0 * q3), \
                    2 * (q1 * q3 + q0 * q2)
                r10, r11, r12 = 2 * (q1 * q2 + q0 * q3), 1 - 2 * (q1 * q1 + q3 * q3), \
                    2 * (q2 * q3 - q0 * q1)
                ox = r00 * wx + r01 * wy + r02 * wz      # ω in the board's frame
                oy = r10 * wx + r11 * wy + r12 * wz
                oz = r20 * wx + r21 * wy + r22 * wz
            rx = h * (s0 * r00 + s1 * r01 + s2 * r02)
            ry = h * (s0 * r10 + s1 * r11 + s2 * r12)
            ux = vx + oy * rz - oz * ry                  # u = v + ω × r
            uy = vy + oz * rx - ox * rz
            uz = vz + ox * ry - oy * rx
            if self.linear:
                fn = c * pen - b * uz                    # ẋ = −u_z
            elif n == 1.0:
                fn = c * pen * (1.0 - b * uz)
            else:
                fn = c * pen ** n * (1.0 - b * uz)
            if fn <= 0.0:
                continue
            scale = -mu * fn / math.sqrt(ux * ux + uy * uy + vs2)
            f0, f1 = scale * ux, scale * uy
            fx += f0
            fy += f1
            fz += fn
            tx += ry * fn - rz * f1                      # τ = r × F
            ty += rz * f0 - rx * fn
            tz += rx * f1 - ry * f0
        if not touching:
            return np.array(free)
        bx = r00 * tx + r10 * ty + r20 * tz              # Rᵀ·τ
        by = r01 * tx + r11 * ty + r21 * tz
        bz = r02 * tx + r12 * ty + r22 * tz
        return np.array([vx, vy, vz, dq0, dq1, dq2, dq3, fx / self.m, fy / self.m,
                         fz / self.m - self.g, (bx + gx) / ia, (by + gy) / ib, (bz + gz) / ic])

    # ------------------------------------------------------------------ invariants
    def energy(self, y: np.ndarray) -> float:
        """Kinetic plus gravitational energy (J) of state ``y`` (the springs' excluded)."""
        v, w = y[7:10], y[10:13]
        return float(0.5 * self.m * v @ v + 0.5 * w @ (self.inertia * w)
                     + self.m * self.g * y[2])

    def angular_momentum(self, y: np.ndarray) -> np.ndarray:
        """The angular momentum about the centre in the board's frame, R·I·ω (kg·m²/s)."""
        return quat_matrix(y[3:7]) @ (self.inertia * y[10:13])


def initial_state(p: np.ndarray, q: np.ndarray, v: np.ndarray, w_body: np.ndarray
                  ) -> np.ndarray:
    """The 13-number state from the centre (m), the quaternion (w, x, y, z, normalised here),
    the velocity (m/s) and the body-frame angular velocity (rad/s)."""
    q = np.asarray(q, dtype=float)
    arrays = [np.asarray(a, dtype=float).reshape(-1) for a in (p, q, v, w_body)]
    for name, a, size in zip(("p", "q", "v", "w_body"), arrays, (3, 4, 3, 3), strict=True):
        if a.size != size or not np.all(np.isfinite(a)):
            raise ValueError(f"{name} = {a.tolist()!r}: must be {size} finite numbers")
    nq = float(np.linalg.norm(arrays[1]))
    if nq == 0.0:
        raise ValueError(f"q = {arrays[1].tolist()!r}: must be a non-zero quaternion")
    arrays[1] = arrays[1] / nq
    return np.concatenate(arrays)


@dataclass
class Trajectory:
    """The integrated states at the requested times.

    Attributes:
        t: the times (s from the start), (n,).
        p: centre positions (m), (n, 3); q: unit quaternions w, x, y, z, (n, 4);
        v: velocities (m/s), (n, 3); w_body: body-frame angular velocities (rad/s), (n, 3).
        evaluations: right-hand-side evaluations (the finite-difference Jacobians' included).
        status: solve_ivp's status (0: reached the end; < 0: failed, the states are NaN from
            the failure on); message: its message.
    """

    t: np.ndarray
    p: np.ndarray
    q: np.ndarray
    v: np.ndarray
    w_body: np.ndarray
    evaluations: int
    status: int
    message: str

    @property
    def states(self) -> np.ndarray:
        """The 13-number states, (n, 13)."""
        return np.column_stack([self.p, self.q, self.v, self.w_body])


def integrate_box(params: BoxContactParams, y0: np.ndarray, t_eval: np.ndarray, *,
                  box: Box = Box(), board_z_m: float = 0.0,
                  gravity_m_s2: float = GRAVITY_M_S2, method: str = METHOD,
                  rtol: float = RTOL, atol: float | np.ndarray = ATOL,
                  max_step: float = MAX_STEP_S,
                  max_evaluations: int = MAX_EVALUATIONS) -> Trajectory:
    """Integrate the box from state ``y0`` (:func:`initial_state`) at t = 0 and return the
    states at the times ``t_eval`` (s, increasing, ≥ 0), quaternions normalised.

    ``method``, ``rtol``, ``atol`` and ``max_step`` go to :func:`scipy.integrate.solve_ivp`
    (module doc for the defaults); after ``max_evaluations`` right-hand sides the integration
    stops (``status`` −2, NaN from there)."""
    model = BoxOnBoard(params, box, board_z_m=board_z_m, gravity_m_s2=gravity_m_s2)
    model.max_evaluations = int(max_evaluations)
    t_eval = np.asarray(t_eval, dtype=float)
    if t_eval.ndim != 1 or t_eval.size == 0 or not np.all(np.isfinite(t_eval)):
        raise ValueError("t_eval: must be a non-empty 1-D array of finite times")
    if t_eval[0] < 0.0 or np.any(np.diff(t_eval) <= 0.0):
        raise ValueError("t_eval: times must be >= 0 and strictly increasing")
    y0 = np.asarray(y0, dtype=float)
    if y0.shape != (13,) or not np.all(np.isfinite(y0)):
        raise ValueError("y0: must be 13 finite numbers (p, q, v, ω)")
    check.positive("rtol", rtol)
    if not (isinstance(max_step, int | float) and max_step > 0.0):
        raise ValueError(f"max_step = {max_step!r}: must be > 0 (inf: no limit)")
    states = np.full((t_eval.size, 13), np.nan)
    status, message = 0, "nothing to integrate"
    if t_eval[-1] > 0.0:
        try:
            sol = integrate.solve_ivp(model.rhs, (0.0, float(t_eval[-1])), y0, method=method,
                                      t_eval=t_eval, rtol=rtol, atol=atol, max_step=max_step)
        except IntegrationBudgetExceeded as exc:
            status, message = -2, str(exc)
        else:
            states[: sol.t.size] = sol.y.T
            status, message = int(sol.status), str(sol.message)
    else:
        states[0] = y0
    q = states[:, 3:7]
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    return Trajectory(t_eval.copy(), states[:, 0:3], q, states[:, 7:10], states[:, 10:13],
                      model.evaluations, status, message)


ZERO_WRENCH = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
""":meth:`CornerWrench.values` when no corner can reach the board (N, N·m)."""


class CornerWrench:
    """The model's corner forces on a box as one force at its centre and a torque (both in
    the board's frame): ``wrench(p, q, v, w_world)`` from the centre (m), the quaternion (w, x,
    y, z), the velocity (m/s) and the angular velocity in the board's frame (rad/s).

    It evaluates the model's own right-hand side (:meth:`BoxOnBoard.rhs`: the normal law and
    the regularised Coulomb friction of every corner below the board) and takes back the force
    m·(v̇ + g·e_z) and the torque R·(I·ω̇ + ω × I·ω).

    :meth:`values` is the same computation on plain floats (an injected replay's every step):
    the 3-vector arithmetic in Python floats — the same IEEE operations as numpy's
    element-wise ones —, the quaternion's norms and the two rotations by R still numpy's
    (BLAS: the summation order and fused multiply–adds are the library's, so the floats are
    the library's too)."""

    def __init__(self, params: BoxContactParams, box: Box | None = None, board_z_m: float = 0.0,
                 gravity_m_s2: float = GRAVITY_M_S2) -> None:
        box = Box() if box is None else box
        self.model = BoxOnBoard(params, box, board_z_m=board_z_m, gravity_m_s2=gravity_m_s2)
        self.model.max_evaluations = math.inf
        self.params, self.box = params, box
        self.board_z, self.g = board_z_m, gravity_m_s2
        self.reach = box.half_width_m * math.sqrt(3.0)
        self.m = box.mass_kg
        self.inertia = box.inertia
        self._inertia = tuple(self.inertia.tolist())
        self._mg = self.m * self.g
        self.zero = (np.zeros(3), np.zeros(3))

    def __call__(self, p: np.ndarray, q: np.ndarray, v: np.ndarray, w_world: np.ndarray
                 ) -> tuple[np.ndarray, np.ndarray]:
        if p[2] - self.reach >= self.board_z:
            return self.zero
        out = self.values(*np.asarray(p, dtype=float).tolist(),
                          *np.asarray(q, dtype=float).tolist(),
                          *np.asarray(v, dtype=float).tolist(),
                          *np.asarray(w_world, dtype=float).tolist())
        return np.array(out[:3]), np.array(out[3:])

    def values(self, px: float, py: float, pz: float, q0: float, q1: float, q2: float,
               q3: float, vx: float, vy: float, vz: float, wx: float, wy: float, wz: float
               ) -> tuple[float, float, float, float, float, float]:
        """(F_x, F_y, F_z, τ_x, τ_y, τ_z) (N, N·m; board frame) at the state p (m), q (w, x,
        y, z), v (m/s), ω (rad/s, board frame), as plain floats; :data:`ZERO_WRENCH` when no
        corner can reach the board."""
        if pz - self.reach >= self.board_z:
            return ZERO_WRENCH
        q = np.array((q0, q1, q2, q3))
        s = math.sqrt(float(q.dot(q)))               # |q| as numpy's dot (BLAS)
        q0, q1, q2, q3 = q0 / s, q1 / s, q2 / s, q3 / s
        q = np.array((q0, q1, q2, q3))
        s = math.sqrt(float(q.dot(q)))               # quat_matrix normalises again
        rot = _matrix(q0 / s, q1 / s, q2 / s, q3 / s)
        wb0, wb1, wb2 = rot.T.dot(np.array((wx, wy, wz))).tolist()   # ω, body frame
        d = self.model.rhs(0.0, np.array((px, py, pz, q0, q1, q2, q3, vx, vy, vz,
                                          wb0, wb1, wb2))).tolist()
        m, (ia, ib, ic) = self.m, self._inertia
        iw0, iw1, iw2 = ia * wb0, ib * wb1, ic * wb2
        tb = np.array((ia * d[10] + (wb1 * iw2 - wb2 * iw1),     # I·ω̇ + ω × Iω
                       ib * d[11] + (wb2 * iw0 - wb0 * iw2),
                       ic * d[12] + (wb0 * iw1 - wb1 * iw0)))
        t0, t1, t2 = rot.dot(tb).tolist()
        return (m * d[7], m * d[8], m * d[9] + self._mg, t0, t1, t2)


__all__ = ["ATOL", "DAIR_CUBE", "LAWS", "MAX_STEP_S", "METHOD", "RTOL", "ZERO_WRENCH", "Box",
           "BoxContactParams", "BoxOnBoard", "CornerWrench", "IntegrationBudgetExceeded",
           "Trajectory", "initial_state", "integrate_box", "quat_matrix", "quat_multiply"]
