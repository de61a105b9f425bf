"""Figure writers behind ``impactbench figures``.

Each module named in :data:`FIGURE_MODULES` exposes ``draw(out_dir, pool)``, which queues
its figures on ``pool`` (an :class:`~concurrent.futures.Executor`: the worker processes of
:func:`impactbench.figures.pool.figure_pool`, or :data:`~impactbench.figures.pool.IN_PROCESS`),
one task a figure, and returns a function that waits for them and gives their paths; and
``write(out_dir: Path) -> list[Path]``, the same drawn here (Agg backend). Those in
:data:`SOLVING_MODULES` run solver sweeps and take ``execution`` (store, fresh, workers,
scheduler) too; the others are closed forms. A module that writes files besides the paths it
returns names them in ``side_files(out_dir)`` (the manifest records them:
:mod:`impactbench.figures.manifest`).
"""

FIGURE_MODULES: tuple[str, ...] = ("impactbench.figures.hunt_crossley",
                                   "impactbench.figures.oblique",
                                   "impactbench.figures.rigid_flexible",
                                   "impactbench.figures.zoo")
SOLVING_MODULES: frozenset[str] = frozenset({"impactbench.figures.rigid_flexible"})
