"""CLI subcommands. Each module exposes ``register(top, groups)`` (see :mod:`impactbench.cli`)."""
