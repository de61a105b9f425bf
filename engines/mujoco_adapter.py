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
runs from 2.5 steps of free flight before first touch (time 0 = the instant of first touch in
free flight) until separation: ball apart from the plate, moving away, with zero force;
rigid–flexible when
:func:`impactbench.reference.laws.no_further_contact` holds (after a collapse — body 2's energy
above the softening law's collapse energy, status ``structure_collapsed`` — once body 2 has
escaped past the potential's peak) or the time cap is reached (``max_time``).
A MuJoCo instability warning (bad qpos/qvel/qacc, which makes MuJoCo reset the state) gives
``diverged``.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, ClassVar, Protocol

import numpy as np
from impactbench.engines.base import Adapter, Builder, EngineUnavailable, RunSettings
from impactbench.engines.common import (
    NATIVE_REFERENCE_VELOCITY_M_S,
    SpringDamper,
    classify,
    native_ball_spring_damper,
)
from impactbench.reference import validation as check
from impactbench.reference.laws import no_further_contact
from impactbench.reference.models import spring_damper
from impactbench.reference.record import ImpactRecord, Status
from impactbench.reference.scenarios import BallOnPlate, RigidFlexible

IMPEDANCE = 1e-4
"""solimp dmin = dmax: MuJoCo's smallest impedance (mjMINIMP), a pure spring–damper."""
SOLIMP: tuple[float, ...] = (IMPEDANCE, IMPEDANCE, 1e-3, 0.5, 2.0)
GAP_STEPS = 2.5
"""Free flight before first touch, in steps (so first touch falls between two samples)."""
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
    <body name="ball" pos="0 0 {r!r}">
      <joint name="drop" type="slide" axis="0 0 1"/>
      <inertial pos="0 0 0" mass="{m!r}" diaginertia="{inertia!r} {inertia!r} {inertia!r}"/>
      <geom name="ball" type="sphere" size="{r!r}"/>
    </body>
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
    <body name="body1" pos="{-r!r} 0 0">
      <joint name="x1" type="slide" axis="1 0 0"/>
      <inertial pos="0 0 0" mass="{s.m1_kg!r}" diaginertia="1 1 1"/>
      <geom name="face1" type="sphere" size="{r!r}"/>
    </body>
    <body name="body2" pos="{r!r} 0 0">
      <joint name="x2" type="slide" axis="1 0 0" stiffness="{s.k2_n_per_m!r}" springref="0"/>
      <inertial pos="0 0 0" mass="{s.m2_kg!r}" diaginertia="1 1 1"/>
      <geom name="face2" type="sphere" size="{r!r}"/>
    </body>
  </worldbody>
  <sensor><contact name="contact" geom1="face1" geom2="face2" data="force" num="1"/></sensor>
</mujoco>"""


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
                raise ValueError(f"param {key} = {value!r}: must be a list of {size} numbers")
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
        self.chunks.append((pre[:, 1:1 + nq], pre[:, 1 + nq:1 + nq + m.nv], sensors[:, 0]))

    def _loop(self, n: int) -> None:
        mujoco = _mujoco()
        m, d, hook, commit = self.model, self.data, self.hook, self.commit
        q, v, sensor = d.qpos, d.qvel, d.sensordata
        step = mujoco.mj_step
        qs, vs, fs = [], [], []
        for _ in range(n):
            qk, vk = q.tolist(), v.tolist()
            arg = hook(qk, vk)
            step(m, d)
            if commit is not None:
                commit(arg)
            qs.append(qk)
            vs.append(vk)
            fs.append(sensor[0])
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

    A stepper may advance more steps than asked (MJX scans in fixed-length chunks); only
    ``sim.steps`` and the arrays count."""
    n = max(1, min(first, n_max))
    while True:
        start = sim.steps
        sim.step_chunk(n)
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


def ball_end_finder() -> EndFinder:
    """End of a ball impact (qpos[:, 0] = the gap): the first sample after first touch with
    zero force, the ball moving away and the surfaces apart."""
    touch: list[int] = []

    def find_end(q: np.ndarray, v: np.ndarray, f: np.ndarray, start: int) -> int | None:
        if not touch:
            touched = np.flatnonzero(f[start:] > 0.0)
            if touched.size == 0:
                return None
            touch.append(start + int(touched[0]))
        lo = max(start, touch[0])
        # zero force, moving away, surfaces apart (a faded Hunt–Crossley force can be 0 in
        # round-off while the surfaces still overlap: that contact lasts until x = 0)
        away = np.flatnonzero((f[lo:] <= 0.0) & (v[lo:, 0] > 0.0) & (q[lo:, 0] > 0.0))
        return lo + int(away[0]) if away.size else None

    return find_end


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
        if not touch:
            touched = np.flatnonzero(f[start:] > 0.0)
            if touched.size == 0:
                return None
            touch.append(start + int(touched[0]))
        # within one free flight the predicate is monotone, and it was false where the
        # previous chunk ended, so searching from the new samples on is enough
        lo = max(start, touch[0])
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


def run_ball(s: BallOnPlate, mode: str, settings: RunSettings) -> ImpactRecord:
    """Ball-on-plate in MuJoCo; see the module docstring for the model and the modes.

    The plane is a half-space: a soft contact may let the ball go while its centre is below
    the surface (a 20 ms default contact at 5 m/s); that is ``tunneled`` only if the ball is
    still moving into the plate when the run ends."""
    dt = float(settings.timestep_s or BALL_TIMESTEP_S)
    user = custom_parameters(settings.params or {}) if mode == "custom" else {}
    out_of_box = mode in ("default", "custom")
    integrator = str(user.get("integrator", settings.options.get(
        "integrator", INTEGRATOR)))
    model, data = _new_model(ball_mjcf(s, dt, integrator, engine_defaults=out_of_box))
    a = measured_diag_a(model, data, (-1e-9,))
    v0, m = s.velocity_m_s, s.mass_kg
    meta: dict[str, Any] = {"integrator": integrator, "efc_diagA": a}
    t_est = hertz_duration_s(s, v0)
    hook = None
    if out_of_box:
        meta["engine_defaults"] = engine_defaults(model)
        if "solref" in user or "solimp" in user:
            set_contact(model, tuple(user.get("solref", model.geom_solref[1])),
                         tuple(user.get("solimp", model.geom_solimp[1])))
        meta.update(params=user, solref=[float(v) for v in model.geom_solref[1]],
                    solimp=[float(v) for v in model.geom_solimp[1]])
        t_est = max(t_est, contact_time_scale_s(meta["solref"], a, m, dt))
    elif mode == "injected":
        solref = _enable_override(model)
        law = s.law()  # the scenario's contact model (Hunt–Crossley family or Kelvin–Voigt)

        def hook(q: list[float], v: list[float]) -> None:
            x = -q[0]
            if x > 0.0:
                # F = k·x + d·ẋ: HC k = c·x^(n−1), d = c·b·xⁿ; Kelvin–Voigt k, d as given
                k, d = spring_damper(law, x)
                solref[0] = -k * a
                solref[1] = -d * a

        meta.update(law=s.model, solimp=list(SOLIMP))
    else:
        v_ref = float(settings.options.get("reference_velocity_m_s",
                                           NATIVE_REFERENCE_VELOCITY_M_S))
        if mode == "native":
            sd = native_ball(s.replace(velocity_m_s=v_ref), v_ref)
            k, d = sd.stiffness_n_per_m, sd.damping_ns_per_m
            t_est = sd.duration_s(m)  # a linear contact's duration does not depend on V0
            meta.update(stiffness_n_per_m=k, damping_ns_per_m=d, reference_velocity_m_s=v_ref)
        else:
            k = d = 0.0
        meta.update(native_or_tuned(model, mode, settings, (-k * a, -d * a)))
    gap = GAP_STEPS * v0 * dt
    data.qpos[0], data.qvel[0] = gap, -v0
    cap = max(20.0 * t_est, DEFAULT_TIME_CAP_S) if out_of_box else 20.0 * t_est
    max_time = settings.max_time_s or gap / v0 + cap
    n_max = max(math.ceil(max_time / dt), math.ceil(GAP_STEPS) + 16)
    first = math.ceil(GAP_STEPS) + math.ceil(t_est / dt) + 2
    chunk = max(8, math.ceil(0.05 * t_est / dt))

    sim = _Sim(model, data, hook)
    out = drive(sim, n_max, first, chunk, ball_end_finder())
    x, rate = -out.qpos[:, 0], -out.qvel[:, 0]
    t = np.arange(x.size) * dt - gap / v0
    meta.update(steps=sim.steps, stepping="python loop" if hook else "rollout")
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
    m_eff = s.m1_kg * s.m2_kg / (s.m1_kg + s.m2_kg)
    t_contact = math.pi * math.sqrt(m_eff / min(s.k1_n_per_m, s.k2_n_per_m))
    n_max = math.ceil((settings.max_time_s or s.max_time_s) / dt)
    chunk = max(64, math.ceil(0.1 * t_contact / dt))
    # a softening structure runs away in finite time after collapse: look often, so the
    # collapse is seen before MuJoCo's own overflow check resets the state
    first = chunk if beta else math.ceil(GAP_STEPS) + math.ceil(2.0 * t_contact / dt)
    collapsed: list[int] = []

    sim = _Sim(model, data, hook, commit)
    out = drive(sim, n_max, first, chunk, rigid_flexible_end_finder(s, structure, collapsed))
    meta.update(steps=sim.steps, stepping="python loop" if hook else "rollout")
    return _mark_unstable(rigid_flexible_record(s, structure, out, dt, gap, meta, collapsed), out)


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


# --------------------------------------------------------------------------- the adapter


class MujocoAdapter(Adapter):
    """MuJoCo (pip ``mujoco``): ball-on-plate and rigid–flexible, all three modes."""

    name = "mujoco"
    pip = "pip install mujoco"
    modes = ("native", "injected", "tuned", "default", "custom")
    parameter_keys = PARAMETER_KEYS
    injection = ("the law through MuJoCo's soft-contact solver: a direct solref scheduled each "
                 "step to the law's secant stiffness and damping at the start state (Euler)")
    builders: ClassVar[dict[str, Builder]] = {
        "ball-on-plate": Builder("run_ball", BALL_TIMESTEP_S),
        "rigid-flexible": Builder("run_rigid_flexible", RIGID_FLEXIBLE_TIMESTEP_S,
                                  modes=("native", "injected", "tuned")),
    }

    def version(self) -> str:
        return str(_mujoco().__version__)

    def run_ball(self, scenario: BallOnPlate, mode: str, settings: RunSettings) -> ImpactRecord:
        if mode == "tuned" and settings.tuned is None:
            return _no_tuned_file()
        return run_ball(scenario, mode, settings)

    def run_rigid_flexible(self, scenario: RigidFlexible, mode: str, settings: RunSettings
                           ) -> ImpactRecord:
        if mode == "tuned" and settings.tuned is None:
            return _no_tuned_file()
        return run_rigid_flexible(scenario, mode, settings)


def _no_tuned_file() -> ImpactRecord:
    return ImpactRecord.failed(
        Status.UNSUPPORTED, "tuned mode needs a tuned-parameter file (none given)")
