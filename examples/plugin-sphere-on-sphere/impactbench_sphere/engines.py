"""The plug-in's engine builder: one function for every engine it names.

An adapter calls a plug-in builder ``"module:function"`` as ``function(adapter, scenario,
mode, settings)`` and expects an :class:`~impactbench.reference.record.ImpactRecord`. This
example does not build its own geometry: it runs the adapter's own ball-on-plate builder on
:meth:`~impactbench_sphere.SphereOnSphere.equivalent_ball` (the same impact, see there). A
real plug-in would build two spheres, one fixed, in each engine here.
"""

from __future__ import annotations

import importlib
from typing import Any

from impactbench.reference.record import ImpactRecord, Status

BALL = "ball-on-plate"


def run(adapter: Any, scenario: Any, mode: str, settings: Any) -> ImpactRecord:
    """Run ``scenario`` (a SphereOnSphere) in ``adapter``'s engine through its ball builder."""
    ball = scenario.equivalent_ball()
    builder = adapter.builders.get(BALL)
    if builder is None:
        return ImpactRecord.failed(Status.UNSUPPORTED, f"{adapter.name} has no {BALL} builder "
                                   "to run the equivalent ball with")
    if builder.modes is not None and mode not in builder.modes:
        return ImpactRecord.failed(Status.UNSUPPORTED, f"{adapter.name} runs {BALL} in "
                                   f"{', '.join(builder.modes)} modes only, not {mode}")
    if ":" in builder.run:  # the ball's builder is itself a module-level function
        module, _, attr = builder.run.partition(":")
        return getattr(importlib.import_module(module), attr)(adapter, ball, mode, settings)
    return getattr(adapter, builder.run)(ball, mode, settings)
