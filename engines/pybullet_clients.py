"""PyBullet DIRECT clients reused between runs: a run's world is Bullet's fresh one either way.

``p.connect(p.DIRECT)`` builds a whole physics server: 8.5 ms on a quiet core, measured
(2026-12, pybullet 3.2.7; 30 ms connect + disconnect at load 2), against 1.5 ms for
``p.resetSimulation`` and ~0.4 ms for a body. A head-on ball at 1/240 s steps a few hundred
times, so connecting was most of such a run (the advisor's PyBullet search: 40 s of 73 in
``connect``, 4752 runs).

What a reset leaves fresh, from Bullet's source (``PhysicsServerCommandProcessor::
resetSimulation`` deletes the dynamics world and calls ``createEmptyDynamicsWorld(flags)``, the
function the server's constructor calls with the same flags 0): the world, its bodies, shapes
and their handles (ids restart at 0), the broadphase and pair cache, the solver and every
``btContactSolverInfo`` field (iterations, ERPs, CFM, slop, split impulse, restitution
threshold), gravity (0) and ``gDbvtMargin``. What it leaves as it was — the server's own fields
— are the step ``fixedTimeStep`` (every world here sets it), ``numSubSteps`` (set back to the
constructor's 0 on release, since ``custom`` runs may set it) and the process-wide
``contactBreakingThreshold`` (every world here sets it). The tests check a reused client's
records bit for bit against fresh clients', a ``custom`` run with every engine key before.
"""

from __future__ import annotations

import contextlib
import threading
from typing import Any

IDLE_MAX = 4
"""Idle clients a process keeps (more only while runs overlap, in threads)."""
FRESH_SUB_STEPS = 0
"""``numSubSteps`` of a new server (``m_numSimulationSubSteps(0)`` in its constructor)."""

_idle: list[int] = []
_lock = threading.Lock()


def acquire(p: Any) -> int:
    """A DIRECT client whose world is empty and fresh: an idle one, else a new one."""
    with _lock:
        cid = _idle.pop() if _idle else None
    return p.connect(p.DIRECT) if cid is None else cid


def release(p: Any, cid: int) -> None:
    """End a run's world: reset it (its memory goes now) and keep the client for the next run,
    or disconnect it where the process keeps enough (or the reset fails)."""
    try:
        p.resetSimulation(physicsClientId=cid)
        p.setPhysicsEngineParameter(numSubSteps=FRESH_SUB_STEPS, physicsClientId=cid)
    except Exception:  # a client that cannot reset is not reused
        with contextlib.suppress(Exception):
            p.disconnect(cid)
        return
    with _lock:
        if len(_idle) < IDLE_MAX:
            _idle.append(cid)
            return
    p.disconnect(cid)


def idle_count() -> int:
    """Clients kept idle in this process (tests)."""
    with _lock:
        return len(_idle)
