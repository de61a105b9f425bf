"""The cases every engine-overhead benchmark times (adapter against a bare stepping loop):
the ball in native mode at the default and the finest timestep and in injected mode, and the
rigid–flexible model native (linear and softening structure) and injected (elastoplastic)."""

from __future__ import annotations

from impactbench.reference.scenarios import BallOnPlate, RigidFlexible

CASES: tuple[tuple[str, BallOnPlate | RigidFlexible, str, float], ...] = (
    ("ball V0=1 native dt=1e-6", BallOnPlate(velocity_m_s=1.0), "native", 1e-6),
    ("ball V0=1 native dt=1e-7", BallOnPlate(velocity_m_s=1.0), "native", 1e-7),
    ("ball V0=5 injected dt=1e-7", BallOnPlate(velocity_m_s=5.0), "injected", 1e-7),
    ("rf lin/lin v1=3.3 native dt=1e-5", RigidFlexible(velocity_m_s=3.3), "native", 1e-5),
    ("rf lin/soft v1=3.3 native dt=1e-5",
     RigidFlexible(velocity_m_s=3.3, structure="softening"), "native", 1e-5),
    ("rf ep/lin v1=3.3 injected dt=1e-5",
     RigidFlexible(velocity_m_s=3.3, local="elastoplastic"), "injected", 1e-5),
)
