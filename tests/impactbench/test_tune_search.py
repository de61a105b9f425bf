"""The one tuner (``impactbench.tuning.search``) on objectives with known answers: its space's
unit coordinates, its budget and memory, and each method — least squares with a batched
Jacobian, Nelder–Mead over categorical combinations, nevergrad a generation at a time — finds
the optimum it must, within its budget, handing the engine populations rather than points.
The fits' own tests (test_tune.py, test_oblique_tuned.py, test_cube_toss_tuning.py) run them
on the engines."""

from __future__ import annotations

import math

import numpy as np
import pytest

from impactbench.tuning import search


class Recorder:
    """A batch objective of a known function, recording each batch it is handed."""

    def __init__(self, f) -> None:
        self.f = f
        self.batches: list[list[dict]] = []

    def evaluate_batch(self, candidates):
        self.batches.append([dict(c) for c in candidates])
        return [float(self.f(c)) for c in candidates]


def test_unit_coordinates_round_trip_and_the_start_is_exact() -> None:
    space = search.KnobSpace((search.Knob("k", 1e2, 1e6), search.Knob("e", 0.0, 0.9, log=False),
                              search.Knob("cone", choices=("pyramidal", "elliptic"))))
    start = space.start_candidate
    assert start == {"k": 1e4, "e": 0.45, "cone": "pyramidal"}  # geometric / arithmetic middle
    assert space.from_unit(space.to_unit(start)) == start
    corner = space.from_unit([0.0, 1.0], {"cone": "elliptic"})
    assert corner == {"k": pytest.approx(1e2, rel=1e-15), "e": 0.9, "cone": "elliptic"}
    far = space.from_unit([2.0, -1.0])  # clipped into the box, never past it
    assert far["k"] == pytest.approx(1e6, rel=1e-15) and far["k"] <= 1e6 and far["e"] == 0.0
    assert space.combos() == [{"cone": "pyramidal"}, {"cone": "elliptic"}]
    with pytest.raises(ValueError, match="a log knob must be > 0"):
        search.KnobSpace((search.Knob("bad", 0.0, 1.0),))


def test_the_budget_stops_a_batch_after_the_candidates_within_it() -> None:
    rec = Recorder(lambda c: c["x"])
    tracker = search.Tracker(rec, max_evals=3, dedupe=True)
    assert tracker.evaluate_batch([{"x": 2.0}, {"x": 2.0}]) == [2.0, 2.0]  # seen once
    with pytest.raises(search.OutOfBudget, match="budget of 3 evaluations spent"):
        tracker.evaluate_batch([{"x": 2.0}, {"x": 1.0}, {"x": 0.5}, {"x": 0.1}])
    # the repeat was served; the two within the budget ran as one batch, the rest never ran
    assert rec.batches == [[{"x": 2.0}], [{"x": 1.0}, {"x": 0.5}]]
    assert tracker.evaluations == 3 and tracker.best == ({"x": 0.5}, 0.5)


def test_least_squares_finds_the_line_and_batches_each_jacobian() -> None:
    """Fit y = a·t + b (a = 3, b = 0.5, inside a log box) from the box's middle: the exact
    answer, each finite-difference Jacobian handed over as one batch of 2 (one per knob)."""
    t = np.linspace(0.0, 1.0, 7)
    space = search.KnobSpace((search.Knob("a", 0.1, 100.0), search.Knob("b", 0.01, 10.0)))
    batches: list[int] = []

    class Line:
        def residuals_batch(self, candidates):
            batches.append(len(candidates))
            return [c["a"] * t + c["b"] - (3.0 * t + 0.5) for c in candidates]

        def evaluate_batch(self, candidates):
            return [float(np.sum(r ** 2)) for r in self.residuals_batch(candidates)]

    out = search.least_squares(space, Line(), diff_step=1e-6)
    assert out.stop == "converged" and "least_squares from start" in out.stages[0]
    assert 2 in batches and set(batches) <= {1, 2}
    # the last stage's J is the converged cost: the exact line
    assert float(out.stages[-1].split("J = ")[1].split()[0]) < 1e-18


def test_nelder_mead_searches_each_combination_within_its_budget() -> None:
    """Minimum at x = 0.3 with the second choice: found to 1e-3, never past the budget, and a
    point seen twice costs one evaluation."""
    space = search.KnobSpace((search.Knob("mode", choices=("a", "b")),
                              search.Knob("x", 0.01, 1.0, log=False)))
    rec = Recorder(lambda c: (c["x"] - 0.3) ** 2 + (c["mode"] == "a"))
    tracker = search.Tracker(rec, max_evals=80, dedupe=True)
    out = search.nelder_mead(space, tracker, seed=1)
    assert tracker.evaluations <= 80 and len(out.stages) == 2
    (best, j) = tracker.best
    assert best["mode"] == "b" and abs(best["x"] - 0.3) < 1e-3 and j < 1e-6
    ran = [search.candidate_key(c) for b in rec.batches for c in b]
    assert len(ran) == len(set(ran)) == tracker.evaluations
    assert max(len(b) for b in rec.batches) > 1  # the Sobol scans went as batches


def test_nevergrad_cma_hands_over_generations_and_improves() -> None:
    knobs = tuple(search.Knob(n, 1e-2, 1e2) for n in ("p", "q", "r"))
    rec = Recorder(lambda c: sum(math.log10(c[n]) ** 2 for n in ("p", "q", "r")) + 1.0)
    j0 = search.nevergrad(knobs, rec, 40, seed=3)
    sizes = [len(b) for b in rec.batches]
    assert sum(sizes) == 40 and j0 == 1.0  # the start is the optimum's middle: log10(1) = 0
    assert max(sizes) > 1  # generations, not points
    assert min(rec.f(c) for b in rec.batches[1:] for c in b) < 1.5


def test_an_unknown_method_is_one_line() -> None:
    with pytest.raises(ValueError, match="method = 'bfgs': must be one of least_squares, "
                                         "nelder_mead, nevergrad"):
        search.search(search.KnobSpace(()), Recorder(lambda c: 0.0), "bfgs")
