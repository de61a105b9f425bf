"""MuJoCo adapter: both scenarios, in ``native``, ``injected``, ``tuned``, ``default`` and
``custom`` modes.

Models (MJCF strings, SI units, gravity per scenario, friction 0, condim 1, one contact pair):

- ball-on-plate: a plane at z = 0 and a sphere (radius R, mass m) on a vertical slide joint
  whose coordinate q is the height of the sphere's lowest point, so the penetration is x = −q.
- rigid–flexible: two large spheres on slide joints along x (q1 = x1, q2 = x2, both 0 at first
  touch), so Δx = x1 − x2; body 2's linear spring is the joint ``stiffness`` k2, the cubic term
  of the softening law (+β·x2³) is applied each step through ``qfrc_applied``. The spheres'
  radius is far larger than any reachable penetration, so the contact normal never flips.

Contact physics of MuJoCo's soft constraint with a *direct* (negative) solref (−S, −D) and a
constant impedance (solimp dmin = dmax = d): K = S/d², B = D/d, aref = −B·v − K·d·pos and
f = (aref − a₀)/(A + R) with R = (1−d)/d·A, hence exactly

    f = (S·x + D·ẋ)/A − d·m_eff·a₀,   A = efc_diagA (1/m ball, 1/m1 + 1/m2 two bodies)

clipped at f ≥ 0 by the solver. So S = K_phys·A and D = D_phys·A give the physical linear
spring–damper K_phys (N/m), D_phys (N·s/m); the leak d·m_eff·a₀ of the other applied forces
(gravity, the structural spring) is 1e-4 of them with d = mjMINIMP = 1e-4 (:data:`IMPEDANCE`).
A is measured from the compiled model (one ``mj_forward`` in contact), not assumed.

Modes:

- ``native``, ball: the clipped linear spring–damper that matches the Hunt–Crossley reference's
  restitution e and duration T at the reference velocity V_ref (default 1 m/s,
  ``options["reference_velocity_m_s"]``), from
  :func:`impactbench.engines.common.native_ball_spring_damper`:
  e(ζ) = e_ref gives ζ, ωd = θe(ζ)/T, ωn = ωd/√(1−ζ²), K = m·ωn², D = 2ζ·√(K·m);
  solref = (−K·A, −D·A), solimp = (d, d, 1 mm, 0.5, 2) on both geoms.
- ``native``, rigid–flexible: the contact stiffness k1 without damping for every local law
  (solref = (−k1·A, 0)) — a user's natural mapping; elastoplastic and mutation are not modelled.
- ``injected`` (injection's one meaning, :attr:`MujocoAdapter.injection`: the law through the
  engine's own contact integration): the reference law is driven through MuJoCo's own contact
  pipeline by scheduling
  the global override solref every step from the current penetration x_k (the same x MuJoCo's
  collision sees at the start of the step): for Hunt–Crossley the secant stiffness c·x^(n−1)
  and damping c·b·xⁿ, each times A; for a local law the secant F1(Δx)/Δx times A (no damping),
  committing the law's memory with ``update(Δx_k)`` after each step. Where the law's force is
  zero (Δx ≤ 0, or inside an elastoplastic permanent set) contacts are disabled for that step,
  so nothing leaks through a zero-force contact.
- ``tuned``: native with ``settings.tuned`` keys ``solref`` (2 numbers, used as given: positive
  (timeconst, dampratio) or direct (−S, −D)) and optional ``solimp`` (5 numbers, default the
  constant impedance above). Without ``settings.tuned`` the mode returns ``unsupported``.
- ``default``: MuJoCo out of the box: the MJCF sets no solref/solimp, so the compiled model
  carries MuJoCo's defaults (solref (0.02, 1): time constant 20 ms, critical damping; solimp
  (0.9, 0.95, 1 mm, 0.5, 2); Euler). Only geometry, mass, the step, gravity and the scenario's
  frictionless single-row contact (condim 1) are set. ``meta["engine_defaults"]`` holds the
  values read back from the compiled model.
- ``custom``: ``default`` with the user's ``settings.params`` by MuJoCo's own names
  (:data:`PARAMETER_KEYS`): ``solref`` (2 numbers, either form), ``solimp`` (5 numbers) on both
  geoms (so MuJoCo's pair mixing keeps them as given) and ``integrator`` (Euler, RK4,
  implicit, implicitfast).

At a step longer than the contact (MuJoCo's customary 2 ms against the paper's 0.1 ms
contact) the run is still measured: MuJoCo's ``refsafe`` clamps a positive time constant to
≥ 2·dt, so the default contact lasts many steps and its restitution is comparable; a stiff
direct solref gives a one- or two-step contact whose duration and peak force the metrics flag
as not resolved.

Integrator: ``Euler`` (semi-implicit: v_{k+1} = v_k + h·a(q_k, v_k), q_{k+1} = q_k + h·v_{k+1}).
Its contact force is evaluated once per step at the start state, which is what injected mode
needs (RK4 would evaluate a scheduled secant stiffness at intermediate stages where it no
longer equals the law) and it is nearly energy-neutral for a stiff spring at ω·h ≪ 1;
``implicitfast`` treats only joint/actuator damping implicitly, so it gains nothing here, and
``discrete``-style dissipation is absent. ``options["integrator"]`` may override it (native).

Measurement: a MuJoCo ``contact`` sensor between the two geoms (data ``force``), which MuJoCo
computes from ``mj_contactForce`` during ``mj_step`` at the step's start state, so sample k is
(state at the start of step k, the contact force acting over step k). Steps run in chunks:
through :func:`mujoco.rollout.rollout` (C++ loop, no Python per step) when nothing must change
between steps (native/tuned with a linear structure), otherwise a lean Python loop. The record
runs from 2.5 steps of free flight before first touch (the head-on ball: 2 + phase,
:func:`~impactbench.engines.base.ball_gap_m`; time 0 = the instant of first touch in free
flight) until separation: ball apart from the plate, moving away, with zero force;
rigid–flexible when
:func:`impactbench.reference.laws.no_further_contact` holds (after a collapse — body 2's energy
above the softening law's collapse energy, status ``structure_collapsed`` — once body 2 has
escaped past the potential's peak) or the time cap is reached (``max_time``).
A MuJoCo instability warning (bad qpos/qvel/qacc, which makes MuJoCo reset the state) gives
``diverged``.

Oblique impact (:func:`run_oblique`; frame and channels of
:mod:`impactbench.engines.oblique_common`): a free sphere (``freejoint``) over the plane, gravity
off, one contact; the contact sensor reports the force and the contact frame (``force normal
tangent``), from which the record takes the normal force and the friction force on the ball
along t; v_t and the spin ω_y come from qvel. A direct solref maps to the physical spring–damper
through the normal compliance A measured on the compiled model (x/F at a static overlap with
solref (−1, 0)): efc_diagA for the elliptic cone, about a quarter of an edge's diagA for the
pyramidal one (its four edges share the normal force).

- ``native``: the ball's native spring–damper on both geoms, condim 3, friction μ on both
  (MuJoCo mixes the larger: the pair has μ), ``impratio`` 1, no ``solreffriction`` (the friction
  rows take the normal's solref); the cone is MuJoCo's default pyramidal, or
  ``options["cone"] = "elliptic"``. Measured (paper's ball, 2 m/s, μ 0.3, dt 1e-6 s): the soft
  friction of the pyramidal cone barely acts during the 0.1 ms impact (spin −98 % at 20° and
  60°), the elliptic one partly (−64 %, −65 %).
- ``injected``: the law through an explicit contact ``<pair>`` whose solref is scheduled each
  step (the ball's secant, times A) and Coulomb friction through MuJoCo's own elliptic cone:
  ``impratio`` 1e4 makes the friction rows a hard constraint against the soft normal, and a
  direct ``solreffriction`` (−1, −d·B) their reference aref = −B·v_slip with
  B = min(20/T, 1/dt) (T: the reference normal duration), so the slip relaxes within 1/20 of
  the contact. Why not "0.0001 1" (ENGINES.md, measured with solimp 0.99): with the constant
  impedance d = 1e-4 a positive solref gives B = 2/(d·τ) = 2e8 1/s, and MuJoCo's elliptic cone
  couples the sliding friction's reference into the normal force (the cone's middle zone):
  restitution 0.78 for 0.91 at 45°. The coupling grows with B; at 20/T it costs ≤ 3e-4 of
  restitution. Measured against the rigid reference at 20°, 45°, 60° (stick), 80° (slide):
  restitution ≤ 3.2e-4, tangential restitution ≤ 4.2e-4, spin ≤ 5.6e-4, rebound angle
  ≤ 3.4e-4 (MuJoCo's contact point sits at mid-overlap: its lever arm is R − x/2).
- ``default``: the geoms' friction (μ, 0.005, 0.0001) on both and nothing else: condim 3,
  pyramidal, impratio 1, solref (0.02, 1), solimp (0.9, 0.95, …) — the soft default contact
  sinks deep (implausible at 2 m/s); ``custom``: that plus the ball's keys and
  :data:`OBLIQUE_KEYS` (``condim``, ``cone``, ``impratio``, ``friction``,
  ``noslip_iterations``, ``solreffriction`` — the last builds a ``<pair>``, where MuJoCo keeps
  it), validated and read back from the compiled model into ``meta["engine_defaults"]``.
- ``tuned``: ``native`` with the friction knobs of a tuned file
  (:data:`impactbench.engines.oblique_tuned.SPACES`: ``cone``, ``impratio``, the geoms' sliding
  ``friction``) written into the model; the normal contact stays native. No file:
  ``unsupported`` with the reason. What the model holds (``opt.cone``, ``opt.impratio``,
  ``geom_friction``) is read back into ``meta["engine_defaults"]``.

Bounce to rest (:func:`run_bounce`, :mod:`impactbench.engines.bounce`): the ball-on-plate
model and contact of every mode for the first impact (:meth:`Bounce.ball`), the ball released
from rest ``height_m`` above the plane with gravity on, stepped at MuJoCo's default 2 ms by
:func:`drive` (rollout chunks; injected: the Python loop of its solref schedule) until the
shared end rule stops it. MuJoCo's contact is soft: there is no restitution velocity
threshold. The plane is a half-space (the contact pushes out from any depth), so a bounce
never counts as tunnelled. Measured at 2 ms from 0.2 m: the default contact (critically
damped, 20 ms) takes the ball in and rests it 0.37 mm deep at 0.44 s; the ~0.1 ms native,
tuned and injected contacts gain energy at the first impact (``diverged``).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable, Generator, Sequence
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np
from impactbench.engines import oblique_tuned
from impactbench.engines.base import (
    RIGID_FLEXIBLE_MODES,
    Adapter,
    EngineUnavailable,
    RunSettings,
    ball_gap_m,
    ball_phase,
    scenario_builders,
)
from impactbench.engines.bounce import BounceEnd
from impactbench.engines.common import (
    NATIVE_REFERENCE_VELOCITY_M_S,
    Recorder,
    SpringDamper,
    classify,
    native_ball_spring_damper,
    reference_velocity,
)
from impactbench.engines.oblique_common import (
    elastic_duration_s,
    finish,
    friction_facts,
    friction_relaxation_rate,
    native_normal,
    record,
    start,
)
from impactbench.reference import validation as check
from impactbench.reference.bounce_scenario import Bounce
from impactbench.reference.laws import no_further_contact
from impactbench.reference.models import spring_damper
from impactbench.reference.record import ImpactRecord, Status
from impactbench.reference.scenarios import BallOnPlate, RigidFlexible
from impactbench.reference.validation import InvalidValue

IMPEDANCE = 1e-4
"""solimp dmin = dmax: MuJoCo's smallest impedance (mjMINIMP), a pure spring–damper."""
SOLIMP: tuple[float, ...] = (IMPEDANCE, IMPEDANCE, 1e-3, 0.5, 2.0)
GAP_STEPS = 2.5
"""Free flight before first touch, in steps (so first touch falls between two samples): the
rigid–flexible pair's, the oblique ball's, and the head-on ball's at the default phase (its
gap is :func:`~impactbench.engines.base.ball_gap_m`, 2 + ``RunSettings.phase`` steps)."""
BALL_TIMESTEP_S = 1e-6
RIGID_FLEXIBLE_TIMESTEP_S = 1e-5
INTEGRATOR = "Euler"
INTEGRATORS = ("Euler", "RK4", "implicit", "implicitfast")
PARAMETER_KEYS: tuple[str, ...] = ("solref", "solimp", "integrator")
"""``custom``-mode keys (MJCF attribute names)."""
DEFAULT_TIME_CAP_S = 1.0
"""``default``/``custom`` ball time cap after first touch (s): the default contact's time
constant (20 ms) is far longer than the physical contact, and a user's solref may be too."""


def _mujoco() -> Any:
    try:
        import mujoco
        import mujoco.rollout  # the batched stepping path
    except ImportError as exc:
        raise EngineUnavailable("mujoco", str(exc)) from exc
    return mujoco


# --------------------------------------------------------------------------- models


def ball_mjcf(scenario: BallOnPlate, timestep_s: float, integrator: str = INTEGRATOR,
              engine_defaults: bool = False) -> str:
    """The ball-on-plate model: plane at z = 0, sphere on a vertical slide joint (q = gap).

    ``engine_defaults`` leaves solimp at MuJoCo's default (``default``/``custom`` modes)."""
    r, m = scenario.radius_m, scenario.mass_kg
    inertia = 0.4 * m * r * r
    solimp = "" if engine_defaults else f' solimp="{_fmt(SOLIMP)}"'
    return f"""<mujoco model="ball_on_plate">
  <option timestep="{timestep_s!r}" gravity="0 0 {-scenario.gravity_m_s2!r}"
          integrator="{integrator}"/>
  <default><geom condim="1" friction="0 0 0"{solimp}/></default>
  <worldbody>
    <geom name="plate" type="plane" size="1 1 0.1"/>
{sphere_body("ball", f"0 0 {r!r}", '<joint name="drop" type="slide" axis="0 0 1"/>', m,
              " ".join([repr(inertia)] * 3), r)}
  </worldbody>
  <sensor><contact name="contact" geom1="ball" geom2="plate" data="force" num="1"/></sensor>
</mujoco>"""


def face_radius_m(scenario: RigidFlexible) -> float:
    """Radius of the two contact spheres: ten times the largest reachable penetration + 1 m.

    Energy bounds the penetration: ½·m1·v1² ≥ ∫F1 dΔx ≥ ½·k_min·Δx² with k_min the softest
    slope any local law can take (k1, kt, k1').
    """
    s = scenario
    k_min = min(s.k1_n_per_m, s.kt_n_per_m, s.k1_failed_n_per_m)
    return 1.0 + 10.0 * s.velocity_m_s * math.sqrt(s.m1_kg / k_min)


def rigid_flexible_mjcf(scenario: RigidFlexible, timestep_s: float,
                        integrator: str = INTEGRATOR) -> str:
    """Two spheres on x-slide joints touching at q = 0; body 2's joint spring is k2."""
    s, r = scenario, face_radius_m(scenario)
    return f"""<mujoco model="rigid_flexible">
  <option timestep="{timestep_s!r}" gravity="0 0 0" integrator="{integrator}"/>
  <default><geom condim="1" friction="0 0 0" solimp="{_fmt(SOLIMP)}"/></default>
  <worldbody>
{sphere_body("body1", f"{-r!r} 0 0", '<joint name="x1" type="slide" axis="1 0 0"/>',
              s.m1_kg, "1 1 1", r, geom="face1")}
{sphere_body("body2", f"{r!r} 0 0", f'<joint name="x2" type="slide" axis="1 0 0" '
              f'stiffness="{s.k2_n_per_m!r}" springref="0"/>', s.m2_kg, "1 1 1", r,
              geom="face2")}
  </worldbody>
  <sensor><contact name="contact" geom1="face1" geom2="face2" data="force" num="1"/></sensor>
</mujoco>"""


def sphere_body(name: str, pos: str | None, joint: str, mass_kg: float, inertia: str,
                radius_m: float, geom_attributes: str = "", geom: str | None = None) -> str:
    """An MJCF ``<body>`` (indented for ``<worldbody>``, at ``pos``, "x y z" in m, or its
    parent's origin) moving on ``joint`` (the joint element: a slide joint, a free joint),
    with an explicit inertial at its centre (``mass_kg``; ``inertia``, the diagonal "Ixx Iyy
    Izz" in kg·m²) and a sphere geom of radius ``radius_m`` (m) named ``geom`` (else the
    body's name), with ``geom_attributes`` appended."""
    at = "" if pos is None else f' pos="{pos}"'
    return f"""    <body name="{name}"{at}>
      {joint}
      <inertial pos="0 0 0" mass="{mass_kg!r}" diaginertia="{inertia}"/>
      <geom name="{geom or name}" type="sphere" size="{radius_m!r}"{geom_attributes}/>
    </body>"""


def _fmt(values: tuple[float, ...] | list[float]) -> str:
    return " ".join(repr(float(v)) for v in values)


def measured_diag_a(model: Any, data: Any, qpos: tuple[float, ...]) -> float:
    """efc_diagA of the contact row at a touching configuration ``qpos`` (1/kg)."""
    mujoco = _mujoco()
    data.qpos[:] = qpos
    data.qvel[:] = 0.0
    mujoco.mj_forward(model, data)
    if data.nefc != 1:
        raise RuntimeError(f"expected one contact row at {qpos}, got {data.nefc}")
    a = float(data.efc_diagA[0])
    mujoco.mj_resetData(model, data)
    return a


def _tuned_parameters(tuned: dict[str, Any]) -> tuple[tuple[float, ...], tuple[float, ...]]:
    """(solref, solimp) from a tuned-parameter table (keys ``solref``, optional ``solimp``)."""
    def numbers(key: str, size: int) -> tuple[float, ...]:
        value = tuned[key]
        if not isinstance(value, list | tuple) or len(value) != size:
            raise ValueError(f"tuned.{key} = {value!r}: must be a list of {size} numbers")
        return tuple(check.finite(f"tuned.{key}[{i}]", v) for i, v in enumerate(value))

    if "solref" not in tuned:
        raise ValueError(f"tuned = {tuned!r}: must contain 'solref' (and optionally 'solimp')")
    solref = numbers("solref", 2)
    solimp = numbers("solimp", 5) if "solimp" in tuned else SOLIMP
    return solref, solimp


def custom_parameters(params: dict[str, Any]) -> dict[str, Any]:
    """Validated ``custom``-mode parameters: solref (2 numbers), solimp (5), integrator."""
    out: dict[str, Any] = {}
    for key, size in (("solref", 2), ("solimp", 5)):
        if key in params:
            value = params[key]
            if not isinstance(value, list | tuple) or len(value) != size:
                raise InvalidValue(f"param {key} = {value!r}: must be a list of {size} numbers")
            out[key] = [check.finite(f"param {key}[{i}]", v) for i, v in enumerate(value)]
    if "integrator" in params:
        out["integrator"] = check.one_of("param integrator", params["integrator"], INTEGRATORS)
    return out


def engine_defaults(model: Any) -> dict[str, Any]:
    """The contact settings MuJoCo compiled for the ball (geom 1), read back from the model."""
    return {"solref": [float(v) for v in model.geom_solref[1]],
            "solimp": [float(v) for v in model.geom_solimp[1]],
            "integrator": _mujoco().mjtIntegrator(model.opt.integrator).name[len("mjINT_"):],
            "condim": int(model.geom_condim[1]), "margin_m": float(model.geom_margin[1])}


# --------------------------------------------------------------------------- stepping


@dataclass
class _Sim:
    """A compiled model, its data and the per-step hook (None: batched rollout)."""

    model: Any
    data: Any
    hook: Callable[[Any, Any], Any] | None = None
    commit: Callable[[float], None] | None = None
    steps: int = 0
    chunks: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = field(default_factory=list)
    sensor_width: int = 1
    """Sensor values kept per step: 1 (the contact sensor's normal force, a 1-D force array)
    or more (the first ``sensor_width`` values of ``sensordata``, a 2-D array)."""

    def step_chunk(self, n: int) -> None:
        """Advance n steps, appending (pre-step qpos, pre-step qvel, force) arrays."""
        if self.hook is None:
            self._rollout(n)
        else:
            self._loop(n)
        self.steps += n

    def _rollout(self, n: int) -> None:
        mujoco = _mujoco()
        m, d = self.model, self.data
        spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
        s0 = np.empty(mujoco.mj_stateSize(m, spec))
        mujoco.mj_getState(m, d, s0, spec)
        warm = d.qacc_warmstart.copy()  # carried over, so chunking does not change the bits
        states, sensors = mujoco.rollout.rollout(m, d, s0[None], nstep=n,
                                                 initial_warmstart=warm[None])
        states, sensors = states[0], sensors[0]
        mujoco.mj_setState(m, d, states[-1], spec)
        pre = np.vstack([s0[None], states[:-1]])
        nq = m.nq
        w = self.sensor_width
        self.chunks.append((pre[:, 1:1 + nq], pre[:, 1 + nq:1 + nq + m.nv],
                            sensors[:, 0] if w == 1 else sensors[:, :w]))

    def _loop(self, n: int) -> None:
        mujoco = _mujoco()
        m, d, hook, commit = self.model, self.data, self.hook, self.commit
        q, v, sensor = d.qpos, d.qvel, d.sensordata
        step = mujoco.mj_step
        w = self.sensor_width
        qs, vs, fs = [], [], []
        for _ in range(n):
            qk, vk = q.tolist(), v.tolist()
            arg = hook(qk, vk)
            step(m, d)
            if commit is not None:
                commit(arg)
            qs.append(qk)
            vs.append(vk)
            fs.append(sensor[0] if w == 1 else sensor[:w].tolist())
        self.chunks.append((np.array(qs), np.array(vs), np.array(fs, dtype=float)))

    def arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        qs, vs, fs = zip(*self.chunks, strict=True)
        return np.concatenate(qs), np.concatenate(vs), np.concatenate(fs)

    def unstable(self) -> bool:
        """MuJoCo flagged a bad state (and reset it): the run diverged."""
        w = _mujoco().mjtWarning
        return any(self.data.warning[int(k)].number > 0
                   for k in (w.mjWARN_BADQPOS, w.mjWARN_BADQVEL, w.mjWARN_BADQACC))


@dataclass
class _Outcome:
    """Stepped history up to the end, and how the run ended."""

    qpos: np.ndarray
    qvel: np.ndarray
    force_n: np.ndarray
    timed_out: bool = False
    unstable: bool = False


EndFinder = Callable[[np.ndarray, np.ndarray, np.ndarray, int], int | None]
"""find_end(qpos, qvel, force, start) → index of the last sample to keep, or None; samples
before ``start`` were already searched."""


class Stepper(Protocol):
    """What :func:`drive` steps: MuJoCo's ``_Sim`` here, and the MJX and Newton adapters'
    simulations (sample k = pre-step qpos, pre-step qvel, the force acting over step k)."""

    steps: int

    def step_chunk(self, n: int) -> None: ...

    def arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]: ...

    def unstable(self) -> bool: ...


def drive(sim: Stepper, n_max: int, first: int, chunk: int, find_end: EndFinder) -> _Outcome:
    """Step in chunks until ``find_end`` returns the last sample to keep, or n_max steps.

    A stepper may advance more steps than asked; only ``sim.steps`` and the arrays count."""
    plan = driving(sim, n_max, first, chunk, find_end)
    try:
        n = next(plan)
        while True:
            sim.step_chunk(n)
            n = plan.send(None)
    except StopIteration as done:
        return done.value


@dataclass
class World:
    """One world of a batch (:func:`drive_many`): the samples it was given, as a
    :class:`Stepper` that its own :func:`driving` plan reads."""

    steps: int = 0
    chunks: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = field(default_factory=list)

    def step_chunk(self, n: int) -> None:  # the batch steps every world together
        raise NotImplementedError

    def arrays(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        qs, vs, fs = zip(*self.chunks, strict=True)
        return np.concatenate(qs), np.concatenate(vs), np.concatenate(fs)

    def unstable(self) -> bool:
        return False


def drive_many(plans: Sequence[Callable[[World], Generator[int, None, _Outcome]]],
               step: Callable[[int], Sequence[tuple[np.ndarray, np.ndarray, np.ndarray]]],
               quantum: int = 1) -> list[tuple[World, _Outcome]]:
    """:func:`drive` for many worlds stepped together: ``plans[k](world)`` is world k's
    :func:`driving` plan; ``step(n)`` advances every world n steps (a multiple of
    ``quantum``, the batch's own chunk) and returns each world's samples of them. Each
    round takes the fewest steps any unfinished world still asks for, so every world is
    given exactly the steps, in the same order, that its lone :func:`drive` takes (a world
    that has ended is stepped on with the others, its samples dropped). Returns each
    world and its outcome."""
    worlds = [World() for _ in plans]
    gens = [plan(world) for plan, world in zip(plans, worlds, strict=True)]

    def owed(n: int) -> int:
        return -(-n // quantum) * quantum

    wants = [owed(next(g)) for g in gens]
    outcomes: list[_Outcome | None] = [None] * len(gens)
    while any(o is None for o in outcomes):
        n = min(w for w, o in zip(wants, outcomes, strict=True) if o is None)
        samples = step(n)
        for k, world in enumerate(worlds):
            if outcomes[k] is not None:
                continue
            world.chunks.append(samples[k])
            world.steps += n
            wants[k] -= n
            if wants[k] == 0:
                try:
                    wants[k] = owed(gens[k].send(None))
                except StopIteration as done:
                    outcomes[k] = done.value
    return [(w, o) for w, o in zip(worlds, outcomes, strict=True)]  # type: ignore[misc]


def driving(sim: Stepper, n_max: int, first: int, chunk: int, find_end: EndFinder
            ) -> Generator[int, None, _Outcome]:
    """:func:`drive` as a generator: it yields how many steps to take next, the caller
    takes them (``sim.step_chunk``) and sends None; it returns the outcome. Many such drives
    can step together (MJX's batch: every world one scan chunk at a time)."""
    n = max(1, min(first, n_max))
    while True:
        start = sim.steps
        yield n
        q, v, f = sim.arrays()
        unstable = sim.unstable()
        if unstable:
            # MuJoCo resets the state to qpos0 = 0, qvel = 0 (never a state of these runs
            # otherwise): keep what came before, where a collapse may already show.
            reset = np.flatnonzero(~np.any(q, axis=1) & ~np.any(v, axis=1))
            stop = int(reset[0]) if reset.size else len(f)
            q, v, f = q[:stop], v[:stop], f[:stop]
        start = min(start, len(f))
        finite = np.all(np.isfinite(q[start:]), axis=1) & np.all(np.isfinite(v[start:]), axis=1)
        if not np.all(finite):
            stop = start + int(np.flatnonzero(~finite)[0]) + 1
            return _Outcome(q[:stop], v[:stop], f[:stop])
        end = find_end(q, v, f, start) if len(f) > start else None
        if end is not None:
            return _Outcome(q[:end + 1], v[:end + 1], f[:end + 1])
        if unstable:
            return _Outcome(q, v, f, unstable=True)
        if sim.steps >= n_max:
            return _Outcome(q, v, f, timed_out=True)
        n = max(1, min(chunk, n_max - sim.steps))


def _after_touch(touch: list[int], f: np.ndarray, start: int) -> int | None:
    """Where an end search starts: the later of ``start`` and first touch (the first sample
    with a normal force ``f`` > 0, found once and kept in ``touch``); None before it."""
    if not touch:
        touched = np.flatnonzero(f[start:] > 0.0)
        if touched.size == 0:
            return None
        touch.append(start + int(touched[0]))
    return max(start, touch[0])


def _away_finder(axis: int, apart: float, force_column: int | None) -> EndFinder:
    """The first sample after first touch with zero normal force, the body moving away
    (``v[:, axis]`` > 0) and apart (``q[:, axis]`` > ``apart``); the force is ``f``, or its
    column ``force_column``."""
    touch: list[int] = []

    def find_end(q: np.ndarray, v: np.ndarray, f: np.ndarray, start: int) -> int | None:
        fn = f if force_column is None else f[:, force_column]
        lo = _after_touch(touch, fn, start)
        if lo is None:
            return None
        away = np.flatnonzero((fn[lo:] <= 0.0) & (v[lo:, axis] > 0.0) & (q[lo:, axis] > apart))
        return lo + int(away[0]) if away.size else None

    return find_end


def ball_end_finder() -> EndFinder:
    """End of a ball impact (qpos[:, 0] = the gap): the first sample after first touch with
    zero force, the ball moving away and the surfaces apart (a faded Hunt–Crossley force can
    be 0 in round-off while the surfaces still overlap: that contact lasts until x = 0)."""
    return _away_finder(0, 0.0, None)


def rigid_flexible_end_finder(s: RigidFlexible, structure: Any,
                              collapsed: list[int]) -> EndFinder:
    """End of a rigid–flexible run (qpos = (x1, x2)): the first sample from which
    :func:`~impactbench.reference.laws.no_further_contact` holds. The first sample where body
    2's energy exceeds the structural law's collapse energy is only flagged (its index goes
    into ``collapsed``): the run goes on until body 2 escapes."""
    touch: list[int] = []

    def find_end(q: np.ndarray, v: np.ndarray, f: np.ndarray, start: int) -> int | None:
        x1, x2, u1, u2 = q[:, 0], q[:, 1], v[:, 0], v[:, 1]
        if math.isfinite(structure.collapse_energy) and not collapsed:
            # flagged only: the run goes on until body 2 escapes (no_further_contact)
            e2 = 0.5 * s.m2_kg * u2[start:] ** 2 + structure.potential(x2[start:])
            over = np.flatnonzero(e2 > structure.collapse_energy)
            if over.size:
                collapsed.append(start + int(over[0]))
        # within one free flight the predicate is monotone, and it was false where the
        # previous chunk ended, so searching from the new samples on is enough
        lo = _after_touch(touch, f, start)
        if lo is None:
            return None
        free = (f[lo:] <= 0.0) & (x1[lo:] < x2[lo:])
        sep = _first_separated(free, lambda i: no_further_contact(
            x1[lo + i], u1[lo + i], x2[lo + i], u2[lo + i], s.m2_kg, structure))
        return None if sep is None else lo + sep

    return find_end


# --------------------------------------------------------------------------- ball on plate


def hertz_duration_s(scenario: BallOnPlate, velocity_m_s: float) -> float:
    """Elastic (b = 0) power-law contact duration (s), an estimate of the run's length:
    T = (2·x_max/V)·√π·Γ(1+1/(n+1))/Γ(1/2+1/(n+1)), x_max = ((n+1)·m·V²/(2c))^(1/(n+1))."""
    s, n1 = scenario, scenario.exponent + 1.0
    x_max = (n1 * s.mass_kg * velocity_m_s**2 / (2.0 * s.stiffness)) ** (1.0 / n1)
    shape = math.sqrt(math.pi) * math.gamma(1.0 + 1.0 / n1) / math.gamma(0.5 + 1.0 / n1)
    return 2.0 * x_max / velocity_m_s * shape


@functools.lru_cache(maxsize=64)
def native_ball(scenario_at_v_ref: BallOnPlate, v_ref: float) -> SpringDamper:
    """Cached native conversion: one reference solve per parameter set, not per velocity."""
    return native_ball_spring_damper(scenario_at_v_ref, v_ref)


def _new_model(mjcf: str) -> tuple[Any, Any]:
    mujoco = _mujoco()
    model = mujoco.MjModel.from_xml_string(mjcf)
    return model, mujoco.MjData(model)


def set_contact(model: Any, solref: tuple[float, ...], solimp: tuple[float, ...]) -> None:
    """The same solref/solimp on every geom, so MuJoCo's pair mixing keeps them as given."""
    model.geom_solref[:] = solref
    model.geom_solimp[:] = solimp


def _enable_override(model: Any) -> Any:
    """Global contact override on; returns the writable o_solref view scheduled each step."""
    model.opt.enableflags |= int(_mujoco().mjtEnableBit.mjENBL_OVERRIDE)
    model.opt.o_solimp[:] = SOLIMP
    model.opt.o_margin = 0.0
    return model.opt.o_solref


def native_or_tuned(model: Any, mode: str, settings: RunSettings,
                     native: tuple[float, ...]) -> dict[str, Any]:
    if mode == "tuned":
        solref, solimp = _tuned_parameters(settings.tuned or {})
    else:
        solref, solimp = native, SOLIMP
    set_contact(model, solref, solimp)
    return {"solref": list(solref), "solimp": list(solimp)}


@dataclass
class BallModel:
    """The ball's compiled model for a mode (:func:`ball_model`), its state not yet set."""

    model: Any
    data: Any
    hook: Callable[[list[float], list[float]], None] | None
    """Injected: the per-step solref schedule (:func:`injected_hook`); else None (rollout)."""
    meta: dict[str, Any]
    """The contact's provenance (integrator, efc_diagA, solref/solimp, defaults, params)."""
    t_est_s: float
    """The contact duration (s) a run is planned with."""


def ball_model(s: BallOnPlate, mode: str, settings: RunSettings, dt: float) -> BallModel:
    """The ball-on-plate model of ``mode`` at step ``dt`` (s), with the mode's contact
    (``injected``: the law's schedule, :func:`injected_hook`; else :func:`ball_contact`):
    the head-on ball's and the bounce's."""
    user = custom_parameters(settings.params or {}) if mode == "custom" else {}
    out_of_box = mode in ("default", "custom")
    integrator = str(user.get("integrator", settings.options.get(
        "integrator", INTEGRATOR)))
    model, data = _new_model(ball_mjcf(s, dt, integrator, engine_defaults=out_of_box))
    a = measured_diag_a(model, data, (-1e-9,))
    meta: dict[str, Any] = {"integrator": integrator, "efc_diagA": a}
    hook = None
    if mode == "injected":
        t_est = hertz_duration_s(s, s.velocity_m_s)
        hook = injected_hook(model, s.law(), a)
        meta.update(law=s.model, solimp=list(SOLIMP))
    else:
        t_est = ball_contact(s, mode, settings, model, dt, a, user, meta)
    return BallModel(model, data, hook, meta, t_est)


def injected_hook(model: Any, law: Any, a: float) -> Callable[[list[float], list[float]], None]:
    """The injected schedule (slide joint, x = −q): before each step in contact, the global
    override solref is set to the law's secant stiffness k and damping d at the start state
    (F = k·x + d·ẋ; Hunt–Crossley k = c·x^(n−1), d = c·b·xⁿ; Kelvin–Voigt k, d as given),
    times the compliance ``a`` (1/kg)."""
    solref = _enable_override(model)

    def hook(q: list[float], v: list[float]) -> None:
        x = -q[0]
        if x > 0.0:
            k, d = spring_damper(law, x)
            solref[0] = -k * a
            solref[1] = -d * a

    return hook


def run_ball(s: BallOnPlate, mode: str, settings: RunSettings) -> ImpactRecord:
    """Ball-on-plate in MuJoCo; see the module docstring for the model and the modes.

    The plane is a half-space: a soft contact may let the ball go while its centre is below
    the surface (a 20 ms default contact at 5 m/s); that is ``tunneled`` only if the ball is
    still moving into the plate when the run ends."""
    dt = float(settings.timestep_s or BALL_TIMESTEP_S)
    built = ball_model(s, mode, settings, dt)
    meta = built.meta
    gap, n_max, first, chunk = ball_start(s, mode, settings, built.data, dt, built.t_est_s, 8)
    sim = _Sim(built.model, built.data, built.hook)
    out = drive(sim, n_max, first, chunk, ball_end_finder())
    meta.update(phase=ball_phase(settings.phase), steps=sim.steps,
                stepping="python loop" if built.hook else "rollout")
    return ball_outcome_record(s, out, dt, gap, meta)


def ball_contact(s: BallOnPlate, mode: str, settings: RunSettings, model: Any, dt: float,
                 a: float, user: dict[str, Any], meta: dict[str, Any]) -> float:
    """Set the ball's contact on ``model`` for a mode other than ``injected`` and record it in
    ``meta`` (MuJoCo's and MJX's): ``default``/``custom`` MuJoCo's own, plus the user's
    solref/solimp; ``native`` the clipped spring–damper matched at V_ref; ``tuned`` the
    tuned solref/solimp. Returns the contact duration (s) the run is planned with."""
    m = s.mass_kg
    t_est = hertz_duration_s(s, s.velocity_m_s)
    if mode in ("default", "custom"):
        meta["engine_defaults"] = engine_defaults(model)
        if "solref" in user or "solimp" in user:
            set_contact(model, tuple(user.get("solref", model.geom_solref[1])),
                         tuple(user.get("solimp", model.geom_solimp[1])))
        meta.update(params=user, solref=[float(v) for v in model.geom_solref[1]],
                    solimp=[float(v) for v in model.geom_solimp[1]])
        return max(t_est, contact_time_scale_s(meta["solref"], a, m, dt))
    v_ref = float(settings.options.get("reference_velocity_m_s", NATIVE_REFERENCE_VELOCITY_M_S))
    k = d = 0.0
    if mode == "native":
        sd = native_ball(s.replace(velocity_m_s=v_ref), v_ref)
        k, d = sd.stiffness_n_per_m, sd.damping_ns_per_m
        t_est = sd.duration_s(m)  # a linear contact's duration does not depend on V0
        meta.update(stiffness_n_per_m=k, damping_ns_per_m=d, reference_velocity_m_s=v_ref)
    meta.update(native_or_tuned(model, mode, settings, (-k * a, -d * a)))
    return t_est


def drive_plan(settings: RunSettings, dt: float, flight_s: float, t_est: float,
               min_chunk: int, min_cap_s: float = 0.0) -> tuple[int, int, int]:
    """How a ball's impact is driven (MuJoCo's, MJX's and Newton's), from the free flight to
    first touch ``flight_s`` (s: the gap over the approach speed, at most 3 steps) and the
    contact duration ``t_est`` (s): (the step cap: ``max_time_s``, else the flight and 20
    contact durations but at least ``min_cap_s``; the first step the end is looked for at;
    the chunk)."""
    max_time = settings.max_time_s or flight_s + max(20.0 * t_est, min_cap_s)
    flight = flight_steps(flight_s, dt)
    n_max = max(math.ceil(max_time / dt), flight + 16)
    first = flight + math.ceil(t_est / dt) + 2
    return n_max, first, max(min_chunk, math.ceil(0.05 * t_est / dt))


def flight_steps(flight_s: float, dt: float) -> int:
    """The whole steps a free flight of ``flight_s`` (s) takes to first touch, rounded up
    (round-off in the gap's last digits ignored: 2.5 steps → 3, 2 steps → 2)."""
    return math.ceil(round(flight_s / dt, 9))


def ball_start(s: BallOnPlate, mode: str, settings: RunSettings, data: Any, dt: float,
               t_est: float, min_chunk: int) -> tuple[float, int, int, int]:
    """Put the ball its gap above the plate at −V0 into ``data``
    (:func:`~impactbench.engines.base.ball_gap_m` at ``settings.phase``: 2 + phase steps of
    flight) and plan the drive (:func:`drive_plan`; ``default``/``custom``: at least
    :data:`DEFAULT_TIME_CAP_S`) (MuJoCo's and MJX's): (the gap (m), the step cap, the first
    step the end is looked for at, the chunk)."""
    v0 = s.velocity_m_s
    gap = ball_gap_m(v0, dt, settings.phase)
    data.qpos[0], data.qvel[0] = gap, -v0
    min_cap = DEFAULT_TIME_CAP_S if mode in ("default", "custom") else 0.0
    return gap, *drive_plan(settings, dt, gap / v0, t_est, min_chunk, min_cap)


def ball_outcome_record(s: BallOnPlate, out: _Outcome, dt: float, gap: float,
                        meta: dict[str, Any]) -> ImpactRecord:
    """The ball's record of a driven run (slide joint: qpos = the gap), classified, and
    ``diverged`` on an instability MuJoCo reported (MuJoCo's and MJX's)."""
    v0, m = s.velocity_m_s, s.mass_kg
    x, rate = -out.qpos[:, 0], -out.qvel[:, 0]
    t = np.arange(x.size) * dt - gap / v0
    rec = ImpactRecord(t, x, rate, out.force_n, rate, np.zeros_like(x), mass_1_kg=m,
                       mass_2_kg=math.inf, meta=meta)
    final = 0.5 * m * rate[-1] ** 2 if x.size else math.nan
    classify(rec, initial_kinetic_j=0.5 * m * v0 * v0, final_kinetic_j=final,
             tunneled=bool(x.size and x[-1] > s.radius_m and rate[-1] >= 0.0),
             timed_out=out.timed_out)
    return _mark_unstable(rec, out)


def contact_time_scale_s(solref: list[float], a: float, m: float, dt: float) -> float:
    """A rough contact duration (s) of a solref, for chunk sizes only: 2·max(τ, 2·dt) for a
    positive time constant τ (MuJoCo's ``refsafe`` clamp), π·√(m/K) with K ≈ S/A for a
    direct (−S, −D)."""
    if solref[0] > 0.0:
        return 2.0 * max(solref[0], 2.0 * dt)
    stiffness = -solref[0] / a
    return math.pi * math.sqrt(m / stiffness) if stiffness > 0.0 else 2.0 * dt


def _mark_unstable(rec: ImpactRecord, out: _Outcome) -> ImpactRecord:
    if out.unstable:
        rec.status = Status.DIVERGED
        rec.message = "MuJoCo reported an unstable state (bad qpos/qvel/qacc) and reset it"
    return rec


# --------------------------------------------------------------------------- bounce to rest


BOUNCE_TIMESTEP_S = 0.002  # MuJoCo's default <option timestep> (mjModel.opt.timestep 0.002 s)
BOUNCE_CHUNK_S = 0.25
"""Simulated time per chunk of a bounce run (s): its end is looked for after each."""


def bounce_start(scenario: Bounce, data: Any, dt: float, settings: RunSettings,
                 min_chunk: int) -> tuple[BounceEnd, EndFinder, int, int, int]:
    """Put the ball at rest with its lowest point ``height_m`` above the plate into ``data``
    (slide joint: q = the gap) and plan the drive (MuJoCo's and MJX's): (the end rule, its
    finder, the step cap of :func:`drive`, the first chunk in steps (the fall and a chunk),
    the chunk in steps: :data:`BOUNCE_CHUNK_S`, at least ``min_chunk``).

    The plane is a half-space: its contact pushes the ball out from any depth, so the end
    rule's tunnel depth is infinite (the ball builder's ``tunneled`` too needs more than
    x > R: the ball still moving in at the end); a ball resting deeper than R is measured
    resting there (``rest_sink_m``)."""
    data.qpos[0], data.qvel[0] = scenario.height_m, 0.0
    end = BounceEnd(scenario, dt, settings.max_time_s, deep_m=math.inf)
    chunk = max(min_chunk, math.ceil(BOUNCE_CHUNK_S / dt))
    first = math.ceil(scenario.fall_time_s / dt) + chunk
    # n_max steps and the state after the last: the cap's record ends there
    return end, bounce_end_finder(end), end.n_max + 1, first, chunk


def bounce_end_finder(end: BounceEnd) -> EndFinder:
    """The bounce's end rule (:class:`~impactbench.engines.bounce.BounceEnd`) over driven
    samples (slide joint: x = −q, ẋ = −q̇): step k ends in sample k+1's state with the force
    f_k it reported, so ``end.ended(x_{k+1}, ẋ_{k+1}, f_k)`` is asked once per step, in
    order, as samples arrive. Returns k+1 for the step that ended the run, ``end.n_max`` once
    that many steps have run (the cap), else None; the same answer once it has one."""
    done: list[int] = []
    checked = [0]  # the next step to ask about

    def find_end(q: np.ndarray, v: np.ndarray, f: np.ndarray, start: int) -> int | None:
        if done:
            return done[0]
        lo, hi = checked[0], min(len(f) - 1, end.n_max)
        ended = end.ended
        xs, vs = q[lo + 1:hi + 1, 0].tolist(), v[lo + 1:hi + 1, 0].tolist()
        for j, (q1, v1, force) in enumerate(zip(xs, vs, f[lo:hi].tolist(), strict=True)):
            if ended(-q1, -v1, force):
                done.append(lo + j + 1)
                return done[0]
        checked[0] = max(lo, hi)
        if checked[0] >= end.n_max:
            done.append(end.n_max)
            return done[0]
        return None

    return find_end


def bounce_record(scenario: Bounce, out: _Outcome, end: BounceEnd, find_end: EndFinder,
                  dt: float, meta: dict[str, Any]) -> ImpactRecord:
    """The bounce's record of a driven run (MuJoCo's and MJX's): every step k as (k·dt, x_k,
    ẋ_k, F_k, ẋ_k), the final state with force 0 (no step taken from it), its status by
    :meth:`BounceEnd.finish`, and ``diverged`` on an instability MuJoCo reported. Samples a
    non-finite state or an instability cut short are given to the end rule first."""
    stop = find_end(out.qpos, out.qvel, out.force_n, 0)
    n = len(out.force_n) if stop is None else stop + 1
    xs = (-out.qpos[:n, 0]).tolist()
    vs = (-out.qvel[:n, 0]).tolist()
    fs = out.force_n[:n].tolist()
    rec = Recorder()
    append = rec.append
    for k in range(n - 1):
        append(k * dt, xs[k], vs[k], fs[k], vs[k])
    append((n - 1) * dt, xs[-1], vs[-1], 0.0, vs[-1])
    meta["steps"] = n - 1
    return _mark_unstable(end.finish(rec, scenario, vs[-1], **meta), out)


def run_bounce(scenario: Bounce, mode: str, settings: RunSettings) -> ImpactRecord:
    """The bounce to rest in MuJoCo: the head-on ball's model and contact for ``mode`` at the
    first impact (:meth:`Bounce.ball`: the plane, a half-space, and the sphere on its slide
    joint, gravity on), the ball released from rest ``height_m`` above the plane, every step
    recorded until :class:`~impactbench.engines.bounce.BounceEnd` ends the run. MuJoCo's
    contact is soft (no restitution threshold). Stepped by :func:`drive`: rollout chunks, or
    the Python loop of the injected schedule."""
    dt = float(settings.timestep_s or BOUNCE_TIMESTEP_S)
    built = ball_model(scenario.ball(), mode, settings, dt)
    end, find_end, n_max, first, chunk = bounce_start(scenario, built.data, dt, settings, 8)
    sim = _Sim(built.model, built.data, built.hook)
    out = drive(sim, n_max, first, chunk, find_end)
    built.meta["stepping"] = "python loop" if built.hook else "rollout"
    return bounce_record(scenario, out, end, find_end, dt, built.meta)


# --------------------------------------------------------------------------- rigid–flexible


def run_rigid_flexible(s: RigidFlexible, mode: str, settings: RunSettings) -> ImpactRecord:
    """Rigid–flexible 2-DOF impact in MuJoCo; see the module docstring."""
    mujoco = _mujoco()
    dt = float(settings.timestep_s or RIGID_FLEXIBLE_TIMESTEP_S)
    integrator = str(settings.options.get("integrator", INTEGRATOR))
    model, data = _new_model(rigid_flexible_mjcf(s, dt, integrator))
    a = measured_diag_a(model, data, (1e-9, 0.0))
    structure = s.structural_law()
    beta = s.beta_n_per_m3 if s.structure == "softening" else 0.0
    qfrc = data.qfrc_applied
    meta: dict[str, Any] = {"integrator": integrator, "efc_diagA": a,
                            "face_radius_m": face_radius_m(s)}
    hook: Callable[[list[float], list[float]], Any] | None = None
    commit = None
    if mode == "injected":
        solref = _enable_override(model)
        opt = model.opt
        enabled = int(opt.disableflags)
        disabled = enabled | int(mujoco.mjtDisableBit.mjDSBL_CONTACT)
        law = s.local_law()

        def hook(q: list[float], v: list[float]) -> float:
            if beta:
                qfrc[1] = beta * q[1] ** 3  # the cubic part of F2 = k2·x2 − β·x2³
            dx = q[0] - q[1]
            force = law.force(dx)
            if force > 0.0:
                opt.disableflags = enabled
                solref[0] = -force / dx * a  # secant F1(Δx)/Δx, no damping
                solref[1] = 0.0
            else:
                opt.disableflags = disabled  # zero law force: no contact row at all
            return dx

        commit = law.update
        meta.update(law=s.local, solimp=list(SOLIMP))
    else:
        meta.update(native_or_tuned(model, mode, settings, (-s.k1_n_per_m * a, 0.0)))
        if mode == "native":
            meta.update(stiffness_n_per_m=s.k1_n_per_m, damping_ns_per_m=0.0)
        if beta:
            def hook(q: list[float], v: list[float]) -> None:
                qfrc[1] = beta * q[1] ** 3

    v1 = s.velocity_m_s
    gap = GAP_STEPS * v1 * dt
    data.qpos[:] = (-gap, 0.0)
    data.qvel[:] = (v1, 0.0)
    sim = _Sim(model, data, hook, commit)
    out, collapsed = drive_pair(sim, s, structure, dt, settings.max_time_s, bool(beta))
    meta.update(steps=sim.steps, stepping="python loop" if hook else "rollout")
    return _mark_unstable(rigid_flexible_record(s, structure, out, dt, gap, meta, collapsed), out)


def drive_pair(sim: Stepper, s: RigidFlexible, structure: Any, dt: float,
               max_time_s: float | None, softening: bool) -> tuple[_Outcome, list[int]]:
    """Drive a 2-DOF run (MuJoCo's and Newton's) to its end (:func:`drive`,
    :func:`rigid_flexible_end_finder`); returns the outcome and the collapse marks.

    The plan, from the contact duration t_c = π·√(m_eff/min(k1, k2)) (s; m_eff = m1·m2/(m1 +
    m2)): the step cap ``max_time_s`` (else the scenario's), chunks of a tenth of t_c (at
    least 64 steps), the end first looked for after the flight and 2·t_c, or after one chunk
    for a ``softening`` structure: it runs away in finite time after collapse, so it is
    looked at often, and the collapse is seen before MuJoCo's own overflow check resets the
    state."""
    n_max, first, chunk = pair_plan(s, dt, max_time_s, softening)
    collapsed: list[int] = []
    out = drive(sim, n_max, first, chunk, rigid_flexible_end_finder(s, structure, collapsed))
    return out, collapsed


def pair_plan(s: RigidFlexible, dt: float, max_time_s: float | None, softening: bool
              ) -> tuple[int, int, int]:
    """:func:`drive_pair`'s plan (MuJoCo's and MJX's): (the step cap, the first step the end
    is looked for at, the chunk), in steps of ``dt`` (s)."""
    m_eff = s.m1_kg * s.m2_kg / (s.m1_kg + s.m2_kg)
    t_contact = math.pi * math.sqrt(m_eff / min(s.k1_n_per_m, s.k2_n_per_m))
    n_max = math.ceil((max_time_s or s.max_time_s) / dt)
    chunk = max(64, math.ceil(0.1 * t_contact / dt))
    first = chunk if softening else math.ceil(GAP_STEPS) + math.ceil(2.0 * t_contact / dt)
    return n_max, first, chunk


def rigid_flexible_record(s: RigidFlexible, structure: Any, out: _Outcome, dt: float,
                          gap: float, meta: dict[str, Any], collapsed: list[int]
                          ) -> ImpactRecord:
    """The 2-DOF record of a driven run (two slide joints: qpos/qvel columns 0 and 1), its
    energy classification, and ``structure_collapsed`` when the end finder saw body 2's
    energy pass the softening law's collapse energy (``collapsed`` non-empty)."""
    v1 = s.velocity_m_s
    x1, x2 = out.qpos[:, 0], out.qpos[:, 1]
    u1, u2 = out.qvel[:, 0], out.qvel[:, 1]
    t = np.arange(x1.size) * dt - gap / v1
    rec = ImpactRecord(t, x1 - x2, u1 - u2, out.force_n, u1, u2, mass_1_kg=s.m1_kg,
                       mass_2_kg=s.m2_kg, displacement_2_m=x2, meta=meta)
    final = (0.5 * s.m1_kg * u1[-1] ** 2 + 0.5 * s.m2_kg * u2[-1] ** 2
             + structure.potential(x2[-1])) if x1.size else math.nan
    classify(rec, initial_kinetic_j=0.5 * s.m1_kg * v1 * v1, final_kinetic_j=final,
             timed_out=out.timed_out)
    if collapsed and rec.status in (Status.OK, Status.MAX_TIME, Status.DIVERGED) \
            and np.all(np.isfinite(out.qpos)):
        rec.status = Status.STRUCTURE_COLLAPSED
        rec.message = (f"body 2's energy exceeded the softening law's collapse energy "
                       f"{structure.collapse_energy:.6g} J")
    return rec


def _first_separated(free: np.ndarray, separated: Callable[[int], bool]) -> int | None:
    """First index where ``separated`` holds, searching runs of free flight (``free`` True).

    Within one run body 1 flies freely away and body 2's energy is conserved, so the predicate
    is monotone there: test the run's last sample, then bisect.
    """
    edges = np.diff(np.concatenate(([0], free.astype(np.int8), [0])))
    starts, stops = np.flatnonzero(edges == 1), np.flatnonzero(edges == -1) - 1
    for lo, hi in zip(starts.tolist(), stops.tolist(), strict=True):
        if not separated(hi):
            continue
        while lo < hi:
            mid = (lo + hi) // 2
            if separated(mid):
                hi = mid
            else:
                lo = mid + 1
        return lo
    return None


# --------------------------------------------------------------------------- oblique impact


OBLIQUE_TIMESTEP_S = 1e-6
CONES = ("pyramidal", "elliptic")
CONDIMS = (1, 3, 4, 6)
OBLIQUE_KEYS: tuple[str, ...] = ("condim", "cone", "impratio", "friction",
                                 "noslip_iterations", "solreffriction")
"""``custom``-mode keys of the oblique scenario only (MJCF names; ``friction`` is the geoms'
sliding, torsional, rolling triple or its sliding value)."""
DEFAULT_FRICTION: tuple[float, float, float] = (1.0, 0.005, 0.0001)
"""MuJoCo's default geom friction (sliding, torsional, rolling)."""
INJECTED_IMPRATIO = 1e4
"""Injected: the friction rows' regulariser is the normal's / 1e4 (R_t = R_n/impratio), so
the elliptic cone's friction is a hard velocity constraint beside the soft scheduled normal
(with impratio 100 the stick is 5 % short: tangential restitution +4.7e-2 at 20°)."""
OBLIQUE_SENSOR_WIDTH = 9
"""The contact sensor's ``force normal tangent``: the force in the contact frame (3), the
frame's normal and tangent (3 + 3), all of the first contact between ball and plate."""


@dataclass(frozen=True)
class ObliqueContact:
    """The contact settings written into the oblique model (None: MuJoCo's default)."""

    condim: int | None = None
    friction: tuple[float, float, float] | None = None
    solref: tuple[float, ...] | None = None
    solimp: tuple[float, ...] | None = None
    solreffriction: tuple[float, ...] | None = None
    cone: str | None = None
    impratio: float | None = None
    noslip_iterations: int | None = None

    @property
    def pair(self) -> bool:
        """A ``<pair>``: ``solreffriction`` exists on explicit pairs only."""
        return self.solreffriction is not None


def oblique_mjcf(s: Any, timestep_s: float, integrator: str, c: ObliqueContact) -> str:
    """The oblique model: a plane at z = 0 and a free sphere (mass m, I = (2/5)·m·R²), one
    contact between them (the geoms' own, or an explicit ``<pair>`` when ``solreffriction`` is
    set), a contact sensor reporting the force and the contact frame."""
    r, m = s.radius_m, s.mass_kg
    inertia = s.moment_of_inertia_kg_m2
    option = "".join(f' {k}="{v}"' for k, v in (
        ("cone", c.cone), ("impratio", None if c.impratio is None else repr(float(c.impratio))),
        ("noslip_iterations", c.noslip_iterations)) if v is not None)
    geom = "".join(f' {k}="{v}"' for k, v in (
        ("condim", c.condim), ("friction", c.friction and _fmt(c.friction)),
        ("solref", c.solref and _fmt(c.solref)), ("solimp", c.solimp and _fmt(c.solimp)))
        if v is not None)
    off = ' contype="0" conaffinity="0"' if c.pair else ""
    pair = ""
    if c.pair:
        sliding, torsional, rolling = c.friction or DEFAULT_FRICTION
        pair = (f'<contact><pair geom1="ball" geom2="plate" condim="{c.condim or 3}" '
                f'friction="{_fmt((sliding, sliding, torsional, rolling, rolling))}" '
                f'solref="{_fmt(c.solref or (0.02, 1.0))}" '
                f'solimp="{_fmt(c.solimp or (0.9, 0.95, 0.001, 0.5, 2.0))}" '
                f'solreffriction="{_fmt(c.solreffriction)}"/></contact>')
    return f"""<mujoco model="oblique">
  <option timestep="{timestep_s!r}" gravity="0 0 0" integrator="{integrator}"{option}/>
  <default><geom{geom}/></default>
  <worldbody>
    <geom name="plate" type="plane" size="1 1 0.1"{off}/>
{sphere_body("ball", None, '<freejoint name="ball"/>', m, " ".join([repr(inertia)] * 3), r, off)}
  </worldbody>
  {pair}
  <sensor><contact name="contact" geom1="ball" geom2="plate" data="force normal tangent"
                   num="1"/></sensor>
</mujoco>"""


def oblique_parameters(params: dict[str, Any]) -> dict[str, Any]:
    """Validated ``custom`` parameters of the oblique scenario: the ball's (solref, solimp,
    integrator) and :data:`OBLIQUE_KEYS` (one-line ValueError naming the key)."""
    out = custom_parameters(params)
    if "condim" in params:
        value = params["condim"]
        if isinstance(value, bool) or value not in CONDIMS:
            raise InvalidValue(f"param condim = {value!r}: must be one of 1, 3, 4, 6")
        out["condim"] = int(value)
    if "cone" in params:
        out["cone"] = check.one_of("param cone", params["cone"], CONES)
    if "impratio" in params:
        out["impratio"] = check.positive("param impratio", params["impratio"])
    if "noslip_iterations" in params:
        value = params["noslip_iterations"]
        if isinstance(value, bool) or not isinstance(value, int | float) \
                or value != int(value) or value < 0:
            raise InvalidValue(f"param noslip_iterations = {value!r}: must be an integer >= 0")
        out["noslip_iterations"] = int(value)
    if "friction" in params:
        value = params["friction"]
        values = list(value) if isinstance(value, list | tuple) else [value]
        if not 1 <= len(values) <= 3:
            raise InvalidValue(f"param friction = {value!r}: must be a number or 1 to 3 numbers "
                             "(sliding, torsional, rolling)")
        got = [check.non_negative(f"param friction[{i}]", v) for i, v in enumerate(values)]
        out["friction"] = got + list(DEFAULT_FRICTION[len(got):])
    if "solreffriction" in params:
        value = params["solreffriction"]
        if not isinstance(value, list | tuple) or len(value) != 2:
            raise InvalidValue(f"param solreffriction = {value!r}: must be a list of 2 numbers")
        out["solreffriction"] = [check.finite(f"param solreffriction[{i}]", v)
                                 for i, v in enumerate(value)]
    return out


def oblique_contact(s: Any, mode: str, settings: RunSettings, user: dict[str, Any]
                    ) -> ObliqueContact:
    """What each mode writes into the model (module doc of the adapter, oblique section)."""
    mu = s.friction
    if mode in ("default", "custom"):
        friction = tuple(user.get("friction", (mu, *DEFAULT_FRICTION[1:])))
        return ObliqueContact(
            condim=user.get("condim"), friction=friction,
            solref=None if "solref" not in user else tuple(user["solref"]),
            solimp=None if "solimp" not in user else tuple(user["solimp"]),
            solreffriction=None if "solreffriction" not in user
            else tuple(user["solreffriction"]),
            cone=user.get("cone"), impratio=user.get("impratio"),
            noslip_iterations=user.get("noslip_iterations"))
    if mode == "tuned":  # native's contact with the fitted friction knobs (``user``)
        return ObliqueContact(condim=3, friction=(float(user["friction"]), 0.0, 0.0),
                              solref=(-1.0, 0.0), solimp=SOLIMP, cone=user["cone"],
                              impratio=float(user["impratio"]))
    if mode == "injected":
        # the solref is scheduled each step; the friction rows' reference (−1, −D) gives
        # aref = −(D/d)·v_slip = −B·v_slip (direct solref, impedance d)
        rate = friction_relaxation_rate(s, float(settings.timestep_s or OBLIQUE_TIMESTEP_S))
        return ObliqueContact(condim=3, friction=(mu, 0.0, 0.0), solref=(-1.0, 0.0),
                              solimp=SOLIMP, solreffriction=(-1.0, -IMPEDANCE * rate),
                              cone="elliptic", impratio=INJECTED_IMPRATIO)
    cone = check.one_of("options.cone", settings.options.get("cone", "pyramidal"), CONES)
    return ObliqueContact(condim=3, friction=(mu, 0.0, 0.0), solref=(-1.0, 0.0),
                          solimp=SOLIMP, cone=cone)


def _set_oblique_solref(model: Any, pair: bool, solref: tuple[float, float]) -> None:
    if pair:
        model.pair_solref[0] = solref
    else:
        model.geom_solref[:] = solref


def oblique_readback(model: Any, data: Any, pair: bool, calibrate: bool) -> dict[str, Any]:
    """At a touching pose (1 nm overlap): the compiled contact's dimension and friction
    (what MuJoCo mixed from the geoms or took from the pair), the normal row's efc_diagA and,
    with ``calibrate``, the normal compliance A (1/kg) with which a direct solref (−S, −D)
    makes the physical spring–damper K = S/A, D_phys = D/A: measured as x/F at a static
    overlap x with solref (−1, 0), the pair's or both geoms' (restored afterwards). A is
    efc_diagA for the elliptic cone; for the pyramidal one the four edges share the normal
    force (A ≈ diagA_edge/4)."""
    mujoco = _mujoco()
    saved = (model.pair_solref[0].copy() if pair else model.geom_solref.copy())
    overlap = 1e-9
    data.qpos[:7] = (0.0, 0.0, model.geom_size[1][0] - overlap, 1.0, 0.0, 0.0, 0.0)
    data.qvel[:] = 0.0
    if calibrate:
        _set_oblique_solref(model, pair, (-1.0, 0.0))
    mujoco.mj_forward(model, data)
    if data.ncon != 1:
        raise RuntimeError(f"expected one contact at a touching pose, got {data.ncon}")
    con = data.contact[0]
    out: dict[str, Any] = {"condim": int(con.dim), "friction_effective": float(con.friction[0]),
                           "efc_diagA": float(data.efc_diagA[con.efc_address])}
    if calibrate:
        f6 = np.zeros(6)
        mujoco.mj_contactForce(model, data, 0, f6)
        out["normal_compliance"] = overlap / float(f6[0])
        if pair:
            model.pair_solref[0] = saved
        else:
            model.geom_solref[:] = saved
    mujoco.mj_resetData(model, data)
    return out


def oblique_facts(model: Any, mode: str, c: ObliqueContact, back: dict[str, Any],
                  mu: float) -> dict[str, Any]:
    """The friction facts of the compiled model (``meta["engine_defaults"]``)."""
    mujoco = _mujoco()
    cone = mujoco.mjtCone(model.opt.cone).name[len("mjCONE_"):].lower()
    pair = c.pair
    if back["condim"] == 1:
        law = "none (condim 1: frictionless)"
    elif mode == "injected":
        law = ("rigid-limit Coulomb: elliptic cone, friction rows a hard velocity constraint "
               f"(impratio {model.opt.impratio:g}) relaxing the slip at "
               f"B = {-model.pair_solreffriction[0][1] / IMPEDANCE:.4g} 1/s "
               "(solreffriction direct (−1, −d·B))")
    else:
        law = (f"soft Coulomb, {cone} cone: the friction rows share the normal's impedance"
               + (f" (÷ impratio {model.opt.impratio:g})" if cone == "elliptic" else "")
               + " and take their reference from "
               + ("solreffriction" if pair else "the normal's solref (solreffriction unset)"))
    extra: dict[str, Any] = {
        "cone": cone, "condim": back["condim"], "impratio": float(model.opt.impratio),
        "noslip_iterations": int(model.opt.noslip_iterations),
        "solref": [float(v) for v in (model.pair_solref[0] if pair else model.geom_solref[1])],
        "solimp": [float(v) for v in (model.pair_solimp[0] if pair else model.geom_solimp[1])],
        "solreffriction": ([float(v) for v in model.pair_solreffriction[0]] if pair
                           else "unset (the normal's solref)"),
        "geom_friction": [float(v) for v in model.geom_friction[1]],
        "integrator": mujoco.mjtIntegrator(model.opt.integrator).name[len("mjINT_"):]}
    if pair:
        extra["pair_friction"] = [float(v) for v in model.pair_friction[0]]
    if mode == "injected":
        extra["solref"] = "scheduled each step: (−k·A, −d·A), the law's secant at the start state"
    rule = "max"  # MuJoCo: the larger of the two geoms' values (equal priority); a pair: its own
    return friction_facts(law, rule, mu, mu, back["friction_effective"],
                          pair="explicit <pair> (its own friction)" if pair else "geoms",
                          **extra)


def oblique_end_finder(radius_m: float) -> EndFinder:
    """End of an oblique run (free joint: qpos[2] = z of the centre, qvel[2] = ż, the force
    array's column 0 = the normal force): the first sample after first touch with zero normal
    force, the ball moving away and apart from the plate (z > R)."""
    return _away_finder(2, radius_m, 0)


def oblique_forces(f: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(normal force, friction force on the ball along +x) from the contact sensor's
    ``force normal tangent`` rows: the sensor gives the force of geom1 (the ball) on geom2 in
    a frame whose normal points from the ball to the plate, so the force on the ball is
    −(f0·n + f1·t + f2·(n × t)); its normal component is f0 (≥ 0)."""
    n, t = f[:, 3:6], f[:, 6:9]
    b = np.cross(n, t)
    tangential = -(f[:, 0] * n[:, 0] + f[:, 1] * t[:, 0] + f[:, 2] * b[:, 0])
    return f[:, 0].copy(), tangential


def prepare_oblique(s: Any, mode: str, settings: RunSettings, engine: str = "mujoco"
                    ) -> tuple[Any, Any, dict[str, Any], ObliqueContact]:
    """Build the oblique model for ``mode`` (MuJoCo's and MJX's, ``engine``): compiled, its
    native solref (native, tuned) or the calibration the injected schedule needs, and the
    metadata."""
    dt = float(settings.timestep_s or OBLIQUE_TIMESTEP_S)
    user = oblique_parameters(settings.params or {}) if mode == "custom" else {}
    if mode == "tuned":
        user = oblique_tuned.friction(engine, settings, s, dt)
    integrator = str(user.get("integrator", settings.options.get("integrator", INTEGRATOR)))
    c = oblique_contact(s, mode, settings, user)
    model, data = _new_model(oblique_mjcf(s, dt, integrator, c))
    calibrate = mode in ("native", "injected", "tuned")
    back = oblique_readback(model, data, c.pair, calibrate)
    meta: dict[str, Any] = {"integrator": integrator, "efc_diagA": back["efc_diagA"],
                            "scenario": s.name}
    mu = c.friction[0] if c.friction else DEFAULT_FRICTION[0]  # set on both geoms
    if mode in ("default", "custom"):
        meta["params"] = user
    elif mode in ("native", "tuned"):
        v_ref = reference_velocity(settings.options)
        sd = native_normal(s, v_ref)
        a = back["normal_compliance"]
        solref = (-sd.stiffness_n_per_m * a, -sd.damping_ns_per_m * a)
        set_contact(model, solref, SOLIMP)
        meta.update(stiffness_n_per_m=sd.stiffness_n_per_m, damping_ns_per_m=sd.damping_ns_per_m,
                    reference_velocity_m_s=v_ref, normal_compliance=a, solref=list(solref),
                    solimp=list(SOLIMP), cone=c.cone)
        if mode == "tuned":
            meta.update(oblique_tuned.meta(user, settings))
    else:
        meta.update(law=s.model, normal_compliance=back["normal_compliance"],
                    solimp=list(SOLIMP), cone=c.cone,
                    friction_relaxation_rate_per_s=-c.solreffriction[1] / IMPEDANCE)
    meta["engine_defaults"] = oblique_facts(model, mode, c, back, mu)
    return model, data, meta, c


def oblique_time_scale_s(s: Any, mode: str, meta: dict[str, Any], dt: float) -> float:
    """A contact duration estimate (s) for chunks and the time cap."""
    t_est = elastic_duration_s(s)
    if mode in ("native", "tuned"):
        return SpringDamper(meta["stiffness_n_per_m"], meta["damping_ns_per_m"]).duration_s(
            s.mass_kg)
    if mode in ("default", "custom"):
        solref = meta["engine_defaults"]["solref"]
        return max(t_est, contact_time_scale_s(solref, meta["efc_diagA"], s.mass_kg, dt))
    return t_est


def oblique_outcome_record(s: Any, out: _Outcome, dt: float, meta: dict[str, Any]
                           ) -> ImpactRecord:
    """The oblique record of a driven run (free joint), classified (MuJoCo's and MJX's)."""
    r = s.radius_m
    st = start(s, dt)
    z = out.qpos[:, 2]
    x, rate = r - z, -out.qvel[:, 2]
    normal, tangential = oblique_forces(out.force_n)
    t = np.arange(x.size) * dt - st.flight_s
    rec = record(s, t, x, rate, normal, out.qvel[:, 0], out.qvel[:, 4], tangential, meta)
    return finish(rec, s, tunneled=bool(x.size and x[-1] > r and rate[-1] >= 0.0),
                  timed_out=out.timed_out)


def oblique_start(s: Any, mode: str, settings: RunSettings, meta: dict[str, Any], data: Any,
                  dt: float, min_chunk: int) -> tuple[int, int, int]:
    """Put the ball at its start (a gap of :data:`GAP_STEPS` steps, the scenario's velocity and
    spin) into ``data`` and plan the drive (MuJoCo's and MJX's): (the step cap, the first
    step the end is looked for at, the chunk), from the contact's time scale."""
    t_est = oblique_time_scale_s(s, mode, meta, dt)
    st = start(s, dt)
    data.qpos[:7] = (0.0, 0.0, s.radius_m + st.gap_m, 1.0, 0.0, 0.0, 0.0)
    data.qvel[:] = (st.tangential_velocity_m_s, 0.0, -st.normal_velocity_m_s, 0.0,
                    st.spin_rad_s, 0.0)
    min_cap = DEFAULT_TIME_CAP_S if mode in ("default", "custom") else 0.0
    return drive_plan(settings, dt, st.flight_s, t_est, min_chunk, min_cap)


def run_oblique(s: Any, mode: str, settings: RunSettings) -> ImpactRecord:
    """The oblique impact in MuJoCo; see the adapter's module doc (oblique section)."""
    dt = float(settings.timestep_s or OBLIQUE_TIMESTEP_S)
    model, data, meta, _ = prepare_oblique(s, mode, settings)
    hook = None
    if mode == "injected":
        ref = model.pair_solref[0]
        law = s.normal_scenario().law()
        a = meta["normal_compliance"]
        r = s.radius_m

        def hook(q: list[float], v: list[float]) -> None:
            x = r - q[2]
            if x > 0.0:
                k, d = spring_damper(law, x)  # F = k·x + d·ẋ at this x
                ref[0] = -k * a
                ref[1] = -d * a

    n_max, first, chunk = oblique_start(s, mode, settings, meta, data, dt, 8)
    sim = _Sim(model, data, hook, sensor_width=OBLIQUE_SENSOR_WIDTH)
    out = drive(sim, n_max, first, chunk, oblique_end_finder(s.radius_m))
    meta.update(steps=sim.steps, stepping="python loop" if hook else "rollout")
    return _mark_unstable(oblique_outcome_record(s, out, dt, meta), out)


# --------------------------------------------------------------------------- the adapter


class MujocoAdapter(Adapter):
    """MuJoCo (pip ``mujoco``): every scenario in every mode (rigid–flexible: native,
    injected and tuned)."""

    name = "mujoco"
    value_check = staticmethod(custom_parameters)
    pip = "pip install mujoco"
    modes = ("native", "injected", "tuned", "default", "custom")
    parameter_keys = PARAMETER_KEYS + OBLIQUE_KEYS
    injection = ("the law through MuJoCo's soft-contact solver: a direct solref scheduled each "
                 "step to the law's secant stiffness and damping at the start state (Euler); "
                 "oblique: Coulomb friction through MuJoCo's elliptic cone, its friction rows "
                 "a hard velocity constraint (impratio 1e4, direct solreffriction relaxing the "
                 "slip within 1/20 of the contact)")
    tuned_parameters = "solref (2 numbers), optional solimp (5 numbers)"
    builders = scenario_builders(
        ball_s=BALL_TIMESTEP_S, pair_s=RIGID_FLEXIBLE_TIMESTEP_S, oblique_s=OBLIQUE_TIMESTEP_S,
        oblique_tuned_check=oblique_tuned.refused, engine_3d="mujoco",
        pair_modes=RIGID_FLEXIBLE_MODES, ball_keys=PARAMETER_KEYS, bounce_s=BOUNCE_TIMESTEP_S)
    # builders only build (Adapter.run has checked the mode, the keys and the tuned file)
    run_ball = staticmethod(run_ball)
    run_rigid_flexible = staticmethod(run_rigid_flexible)
    run_oblique = staticmethod(run_oblique)
    run_bounce = staticmethod(run_bounce)

    def version(self) -> str:
        return str(_mujoco().__version__)
