"""``replay(engine, mode, …)``: the cube tosses replayed in one engine from Python.

A convenience over the one door: it builds the scenario
(:class:`~impactbench.scenarios.cube_toss.CubeToss`) from the protocol, the box and the toss
selection, and runs it through :func:`impactbench.evaluate.compare` (the engine's adapter and
its cube-toss builder), returning the run object ``impactbench run cube-toss --json`` prints.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

import impactbench.cube_tosses.data as data_mod
from impactbench.cube_tosses.protocol import Box, Protocol
from impactbench.scenarios.cube_toss import CubeToss


def replay(engine: str, mode: str = "default", tosses: str | int | list[int] = "all",
           param_set: str | None = None, data: Any = None, *,
           params: Mapping[str, Any] | None = None, protocol: Protocol | None = None,
           box: Box | None = None, timestep_s: float | None = None) -> dict[str, Any]:
    """Replay ``tosses`` (a split name, an id or ids) of ``data`` (a CSV path, a DataFrame of
    its columns, written to a temporary CSV; None: the packaged tosses) in ``engine`` through
    its adapter's cube-toss builder (the one door) and return the run object ``impactbench
    run cube-toss --json`` prints: status, the metrics,
    ``per_toss``, ``split``, ``protocol``, ``engine_setup``, … ``param_set`` (custom mode) names
    a published set, ``params`` are engine parameters by the builder's own names (custom) or
    the fitted ones (tuned); ``protocol`` and ``box`` set the scenario's fields."""
    import pandas as pd

    from impactbench.engines.base import RunSettings
    from impactbench.evaluate import compare

    if isinstance(data, pd.DataFrame):
        import tempfile

        with tempfile.TemporaryDirectory() as folder:
            path = Path(folder) / "tosses.csv"
            data_mod.validate(data).to_csv(path, index=False)
            return replay(engine, mode, tosses, param_set, path, params=params,
                          protocol=protocol, box=box, timestep_s=timestep_s)
    if mode in ("default", "native", "injected") and (param_set is not None or params):
        what = ("sets no engine parameters" if mode == "default" else
                "maps the reference model's contact" if mode == "native" else
                "applies the reference model's corner forces")
        raise ValueError(f"param_set = {param_set!r}: {mode} mode {what}; use mode "
                         "'custom' to set engine parameters")
    if mode == "tuned" and param_set is not None:
        raise ValueError(f"param_set = {param_set!r}: tuned mode takes the fitted parameters "
                         "(params = load_tuned(engine)), no parameter set")
    if mode == "tuned" and not params:
        raise ValueError(f"params = {params!r}: tuned mode needs the fitted parameters "
                         "(params = load_tuned(engine))")
    protocol = protocol or Protocol()
    box = box or Box()
    selection = tosses if isinstance(tosses, str) else ",".join(
        str(int(i)) for i in ([tosses] if isinstance(tosses, int | np.integer) else tosses))
    scenario = CubeToss(half_width_m=box.half_width_m, mass_kg=box.mass_kg,
                        inertia_kg_m2=box.inertia_kg_m2, data=str(data) if data else "",
                        tosses=selection, substeps=protocol.substeps,
                        start_rule=protocol.start_rule, samples_before=protocol.samples_before,
                        refit=protocol.refit, min_preceding=protocol.min_preceding,
                        velocity_fit=protocol.velocity_fit, sample_dt_s=protocol.sample_dt_s,
                        board_z_m=protocol.board_z_m)
    given = dict(params or {}) | ({"param_set": param_set} if param_set is not None else {})
    settings = RunSettings(timestep_s=timestep_s,
                           params=given if mode == "custom" else None,
                           tuned=given if mode == "tuned" else None)
    out, _ = compare(engine, scenario, mode, settings)
    return {**out, "param_set": param_set}
