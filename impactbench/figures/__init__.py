"""Figure writers behind ``impactbench figures``.

Each module named in :data:`FIGURE_MODULES` exposes ``write(out_dir: Path) -> list[Path]``,
writes its PNGs into ``out_dir`` (Agg backend) and returns their paths. Those in
:data:`SOLVING_MODULES` run solver sweeps and take ``execution`` (store, fresh, workers,
scheduler) too; the others are closed forms.
"""

FIGURE_MODULES: tuple[str, ...] = ("impactbench.figures.hunt_crossley",
                                   "impactbench.figures.oblique",
                                   "impactbench.figures.rigid_flexible",
                                   "impactbench.figures.zoo")
SOLVING_MODULES: frozenset[str] = frozenset({"impactbench.figures.rigid_flexible"})
