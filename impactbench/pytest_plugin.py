"""pytest plugin: one test item per accuracy-gate check (see :mod:`impactbench.gates`).

Registered through the ``pytest11`` entry point ``impactbench``, so any project with
impactbench installed can run::

    pytest --impactbench-gates=gates.toml [--impactbench-baseline=gates_baseline.json]
           [--impactbench-strict] [--impactbench-jobs=2]

Each check becomes an item ``<gate file>::gate[<check id>]``, e.g.
``gates.toml::gate[mujoco-injected-ball-on-plate-v1-dt1e-06-restitution]``, so ``-k`` selects
checks by engine, mode, velocity or metric. The engine runs the selected items need are run
once, deduplicated and in parallel worker processes, when the first item runs. Marks map to
outcomes: ``pass``/``better`` pass, ``fail``/``worse``/``new-failure`` fail with the check's
numbers, ``not-comparable`` (engine not installed, mode unsupported) is skipped, or fails under
``--impactbench-strict``. A bad gate file is a usage error (pytest exits 4).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from impactbench import gates

_OUTCOMES = pytest.StashKey[dict[str, gates.Outcome]]()


def pytest_addoption(parser: pytest.Parser) -> None:
    group = parser.getgroup("impactbench", "impactbench accuracy gates")
    group.addoption("--impactbench-gates", metavar="FILE", default=None,
                    help="gate file (TOML): add one test item per gate check")
    group.addoption("--impactbench-baseline", metavar="FILE", default=None,
                    help="baseline of measured values (JSON) for the worse/new-failure marks")
    group.addoption("--impactbench-strict", action="store_true", default=False,
                    help="not-comparable gate checks (missing engine) fail instead of skip")
    group.addoption("--impactbench-jobs", metavar="N", type=int, default=2,
                    help="worker processes for the gate runs (default 2)")


class GateCheckFailed(Exception):
    """A gate check's mark is failing."""


class GateFile(pytest.File):
    """The gate file as a collector of its checks."""

    def collect(self):
        try:
            parsed = gates.load_gates(self.path)
        except ValueError as exc:
            raise pytest.UsageError(str(exc)) from None
        for c in parsed.checks:
            yield GateItem.from_parent(self, name=f"gate[{c.id}]", check=c)


class GateItem(pytest.Item):
    """One check: passes, fails with its numbers, or skips when not comparable."""

    def __init__(self, *, check: gates.Check, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        self.check = check
        self.add_marker(pytest.mark.impactbench_gate)

    def runtest(self) -> None:
        outcome = _outcomes(self.session)[self.check.id]
        self.user_properties.append(("mark", outcome.mark))
        self.user_properties.append(("rel_error", outcome.rel_error))
        if outcome.mark == gates.NOT_COMPARABLE:
            if self.config.getoption("impactbench_strict"):
                raise GateCheckFailed(f"not-comparable (strict): {outcome.message}")
            pytest.skip(f"not comparable: {outcome.message}")
        if outcome.failed:
            raise GateCheckFailed(f"{outcome.mark}: {outcome.message} (value {outcome.value:.6g}"
                                  f", reference {outcome.reference:.6g}, rel error "
                                  f"{outcome.rel_error:+.3g}, tolerance "
                                  f"{self.check.tolerance:g})")

    def repr_failure(self, excinfo: pytest.ExceptionInfo[BaseException],
                     style: Any = None) -> str:
        if isinstance(excinfo.value, GateCheckFailed):
            return f"gate check {self.check.id}: {excinfo.value}"
        return super().repr_failure(excinfo, style)

    def reportinfo(self) -> tuple[Path, int, str]:
        return self.path, max(self.check.line - 1, 0), f"gate[{self.check.id}]"


def _outcomes(session: pytest.Session) -> dict[str, gates.Outcome]:
    """Run every selected gate item's engine runs once (deduplicated, parallel) and judge."""
    config = session.config
    if _OUTCOMES not in config.stash:
        checks = [item.check for item in session.items if isinstance(item, GateItem)]
        baseline = gates.load_baseline(config.getoption("impactbench_baseline"))
        outcomes = gates.evaluate(checks, baseline,
                                  jobs=config.getoption("impactbench_jobs"))
        config.stash[_OUTCOMES] = {o.check.id: o for o in outcomes}
    return config.stash[_OUTCOMES]


def pytest_configure(config: pytest.Config) -> None:
    config.addinivalue_line("markers", "impactbench_gate: an impactbench accuracy-gate check")


@pytest.hookimpl(tryfirst=True)
def pytest_collection_modifyitems(session: pytest.Session, config: pytest.Config,
                                  items: list[pytest.Item]) -> None:
    """Append the gate file's checks (before -k/-m deselection sees the items)."""
    path = config.getoption("impactbench_gates")
    if not path:
        return
    path = Path(path)
    if not path.is_absolute():
        path = config.invocation_params.dir / path
    if not path.is_file():
        raise pytest.UsageError(f"--impactbench-gates = {str(path)!r}: no such file")
    collector = GateFile.from_parent(session, path=path)
    items.extend(collector.collect())


def pytest_report_collectionfinish(config: pytest.Config, start_path: Path,
                                   items: list[pytest.Item]) -> str | None:
    n = sum(isinstance(item, GateItem) for item in items)
    path = config.getoption("impactbench_gates")
    return f"impactbench: {n} gate checks selected from {path}" if path else None
