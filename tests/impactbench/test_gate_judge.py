"""The gate judge (``gates.judge``, ``gates.drift``) on synthetic errors of both signs.

``test_gates.py`` judges real measured errors, whose signs happen to be what they are; here
every branch of the marking rule (module docstring of ``impactbench.gates``) is driven by
hand-made results: in and out of tolerance on each side, exactly at the tolerance, baseline
drift up and down, sign flips that shrink and that do not, the absolute floor, the statuses
that are not comparable, ``implausible`` (``impactbench.plausibility``), and runs that
produced no number. The band numbers are chosen exactly representable in binary so the
boundaries (``≤``) are tested to the last bit.
"""

from __future__ import annotations

import math

import pytest

from impactbench import gates, scenarios
from impactbench.matrix import RunKey
from impactbench.plausibility import IMPLAUSIBLE

RUN = RunKey("mujoco", "ball-on-plate", (("velocity_m_s", 1.0),), "injected", 1e-6)
TOL = 0.01


def check(tolerance: float = TOL, margin: float = gates.DEFAULT_MARGIN,
          floor: float = gates.DEFAULT_FLOOR) -> gates.Check:
    return gates.Check(RUN, "restitution", tolerance, margin, floor)


def result(rel_error: float | None, status: str = "ok", **extra) -> dict:
    out = {"status": status, "reference": {"restitution": 0.8}, "engine_version": "3.1.0",
           "wall_s": 0.25, **extra}
    if rel_error is not None:
        out["restitution"] = 0.8 * (1.0 + rel_error)
        out["rel_error"] = {"restitution": rel_error}
    return out


def judge(err: float | None, base: float | None = None, status: str = "ok",
          c: gates.Check | None = None, **extra) -> gates.Outcome:
    c = c or check()
    baseline = None if base is None else {c.id: {"rel_error": base}}
    return gates.judge(c, result(err, status, **extra), baseline)


# ------------------------------------------------------------------ tolerance, no baseline


@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_within_and_beyond_tolerance_either_sign(sign: float) -> None:
    for err in (0.0, 1e-9, 0.5 * TOL, 0.999 * TOL, TOL):  # |err| ≤ tolerance passes
        out = judge(sign * err)
        assert out.mark == gates.PASS, err
        assert not out.failed and out.message == ""
        assert out.rel_error == sign * err and out.baseline_rel_error is None
    for err in (1.001 * TOL, 2 * TOL, 1e3):
        out = judge(sign * err)
        assert out.mark == gates.FAIL and out.failed, err
        assert out.message == f"|rel error| {abs(err):.3g} > tolerance {TOL:g}"


def test_tolerance_boundary_to_the_last_bit() -> None:
    c = check(tolerance=0.25)
    assert judge(0.25, c=c).mark == gates.PASS
    assert judge(-0.25, c=c).mark == gates.PASS
    assert judge(math.nextafter(0.25, 1.0), c=c).mark == gates.FAIL
    assert judge(math.nextafter(-0.25, -1.0), c=c).mark == gates.FAIL
    zero = check(tolerance=0.0)  # tolerance 0: only an exact result passes
    assert judge(0.0, c=zero).mark == gates.PASS
    assert judge(5e-324, c=zero).mark == gates.FAIL
    assert judge(-5e-324, c=zero).mark == gates.FAIL


def test_outcome_carries_the_measurement() -> None:
    out = judge(-0.004)
    assert out.value == pytest.approx(0.8 * 0.996, rel=1e-15)
    assert out.reference == 0.8 and out.rel_error == -0.004
    assert out.engine_version == "3.1.0" and out.wall_s == 0.25
    assert out.status == "ok" and out.check.id.endswith("-restitution")


@pytest.mark.parametrize("err", [math.nan, math.inf, -math.inf, None])
def test_no_number_fails(err) -> None:
    out = judge(err, status="ok")
    assert out.mark == gates.FAIL
    assert out.message.startswith("no value (status ok")


@pytest.mark.parametrize("status", ["crashed", "diverged", "tunneled", "no_contact",
                                    "max_time", "structure_collapsed"])
def test_failed_runs_fail_and_are_new_failures_after_a_passing_baseline(status: str) -> None:
    out = judge(None, status=status, message="boom")
    assert out.mark == gates.FAIL and out.status == status
    assert out.message == f"no value (status {status}: boom)"
    assert judge(None, base=0.001, status=status).mark == gates.NEW_FAILURE
    assert judge(None, base=-0.001, status=status).mark == gates.NEW_FAILURE
    assert judge(None, base=2 * TOL, status=status).mark == gates.FAIL  # it failed before too


def test_an_empty_result_is_a_crash() -> None:
    out = gates.judge(check(), {})
    assert out.mark == gates.FAIL and out.status == "crashed"
    assert math.isnan(out.rel_error) and math.isnan(out.value)


# ------------------------------------------------------------------ statuses


@pytest.mark.parametrize("status", sorted(gates.NOT_COMPARABLE_STATUSES))
def test_not_comparable_statuses(status: str) -> None:
    assert gates.NOT_COMPARABLE_STATUSES == {"unavailable", "unsupported"}
    for err, base in ((None, None), (0.0, None), (0.5, None), (None, 0.001), (0.5, 0.001)):
        out = judge(err, base=base, status=status, message="not installed")
        assert out.mark == gates.NOT_COMPARABLE, (err, base)
        assert not out.failed
        assert out.message == f"{status}: not installed"
    outcomes = [judge(0.001), judge(None, status=status)]
    assert gates.exit_code(outcomes) == 0
    assert gates.exit_code(outcomes, strict=True) == 1
    assert gates.judge(check(), {"status": status}).message == status


def test_implausible_fails_however_small_its_error() -> None:
    why = "penetration 0.31 of the body's size (limit 0.1)"
    for err in (0.0, 1e-6, -1e-6):
        out = judge(err, status=IMPLAUSIBLE, message=why)
        assert out.mark == gates.FAIL and out.failed, err
        assert out.message == why and out.rel_error == err
        # a baseline that passed (either sign): a new failure; one that failed: still fail
        assert judge(err, base=0.002, status=IMPLAUSIBLE).mark == gates.NEW_FAILURE
        assert judge(err, base=-0.002, status=IMPLAUSIBLE).mark == gates.NEW_FAILURE
        assert judge(err, base=-2 * TOL, status=IMPLAUSIBLE).mark == gates.FAIL
    assert judge(0.0, status=IMPLAUSIBLE).message == IMPLAUSIBLE  # no message given


# ------------------------------------------------------------------ against a baseline


@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_drift_both_ways_around_a_baseline_of_either_sign(sign: float) -> None:
    """base = ±1, margin 1/4, floor 0: band 1/4; pass within [3/4, 5/4]·base, better where
    |err| ≤ 3/4 on either side of zero (a shrink, sign flip or not), worse beyond."""
    c = check(tolerance=2.0, margin=0.25, floor=0.0)
    base = sign * 1.0

    def mark(err: float) -> str:
        return judge(sign * err, base=base, c=c).mark

    for err in (1.0, 0.9, 1.1, 0.75, 1.25):  # inside the band, boundaries included
        assert mark(err) == gates.PASS, err
    assert mark(math.nextafter(1.25, 2.0)) == gates.WORSE  # grew past the band
    assert mark(1.9) == gates.WORSE
    assert mark(math.nextafter(0.75, 0.0)) == gates.BETTER  # shrank past the band
    for err in (0.5, 0.0, -0.5, -0.75):  # shrank; the sign flip is fine when it shrinks
        assert mark(err) == gates.BETTER, err
    for err in (math.nextafter(-0.75, -1.0), -1.0, -1.25, -1.9):  # flipped, did not shrink
        assert mark(err) == gates.WORSE, err
    # beyond tolerance (2), either sign: the baseline (|1| ≤ 2) passed, so a new failure
    assert mark(2.5) == gates.NEW_FAILURE
    assert mark(-2.5) == gates.NEW_FAILURE
    assert judge(sign * 2.5, base=sign * 3.0, c=c).mark == gates.FAIL  # both failing


def test_drift_messages_name_the_direction() -> None:
    c = check(tolerance=2.0, margin=0.25, floor=0.0)
    worse = judge(-1.0, base=1.0, c=c)
    assert worse.mark == gates.WORSE and worse.failed
    assert worse.message == ("rel error -1 moved from baseline +1 by -2, beyond ±0.25 "
                             "(0.25·|base| + 0)")
    better = judge(0.5, base=1.0, c=c)
    assert better.mark == gates.BETTER and not better.failed
    assert better.message == "rel error +0.5 shrank from baseline +1"
    assert better.baseline_rel_error == 1.0


def test_floor_absorbs_round_off_around_a_zero_baseline() -> None:
    c = check(margin=0.5, floor=1e-8)
    for err in (0.0, 5e-9, -5e-9, 1e-8, -1e-8):
        assert judge(err, base=0.0, c=c).mark == gates.PASS, err
    for err in (2e-8, -2e-8, 1e-6):
        assert judge(err, base=0.0, c=c).mark == gates.WORSE, err
    # an error at round-off (1e-13) may flip sign: inside the floor
    assert judge(-1e-13, base=1e-13, c=c).mark == gates.PASS
    # without a floor the same flip is worse; the margin alone is relative
    assert judge(-1e-13, base=1e-13, c=check(margin=0.5, floor=0.0)).mark == gates.WORSE


def test_drift_function_directly() -> None:
    """band = margin·|base| + floor, with a floor that matters."""
    margin, floor = 0.5, 0.25
    assert gates.drift(1.0, 1.0, margin, floor) == (gates.PASS, "")
    band = margin * 1.0 + floor  # 0.75
    assert gates.drift(1.0 + band, 1.0, margin, floor)[0] == gates.PASS
    assert gates.drift(math.nextafter(1.0 + band, 9.0), 1.0, margin, floor)[0] == gates.WORSE
    assert gates.drift(1.0 - band, 1.0, margin, floor)[0] == gates.PASS  # 0.25: in the band
    assert gates.drift(0.2, 1.0, margin, floor)[0] == gates.BETTER  # |0.2| ≤ 1 − 0.75
    assert gates.drift(-0.25, 1.0, margin, floor)[0] == gates.BETTER
    assert gates.drift(math.nextafter(-0.25, -1.0), 1.0, margin, floor)[0] == gates.WORSE
    assert gates.drift(-1.0, -1.0, 0.0, 0.0) == (gates.PASS, "")
    assert gates.drift(math.nextafter(-1.0, 0.0), -1.0, 0.0, 0.0)[0] == gates.BETTER
    assert gates.drift(math.nextafter(-1.0, -2.0), -1.0, 0.0, 0.0)[0] == gates.WORSE


def test_baseline_entries_that_do_not_count() -> None:
    c = check()
    other = {"mujoco-native-ball-on-plate-v1-dt1e-06-restitution": {"rel_error": 1e-9}}
    assert gates.judge(c, result(0.005), other).mark == gates.PASS  # another check's entry
    for entry in ({}, {"rel_error": None}, {"rel_error": math.nan}, {"rel_error": "x"}):
        out = gates.judge(c, result(0.005), {c.id: entry})
        assert out.mark == gates.PASS and out.baseline_rel_error is None, entry
        assert gates.judge(c, result(0.05), {c.id: entry}).mark == gates.FAIL  # not "new"


def test_rejudge_and_updated_baseline_round_trip() -> None:
    c = check(margin=0.5, floor=0.0)
    first = [gates.judge(c, result(0.004))]
    base = gates.updated_baseline(first)
    assert base[c.id]["rel_error"] == 0.004 and base[c.id]["status"] == "ok"
    drifted = gates.rejudge([gates.judge(c, result(-0.004))], base)
    assert drifted[0].mark == gates.WORSE
    # not-comparable and valueless outcomes keep the previous entry
    kept = gates.updated_baseline([judge(None, status="unavailable"),
                                   judge(None, status="crashed")], base)
    assert kept == base


# ------------------------------------------------------------------ defaults and edges


def test_absent_fields_have_their_defaults() -> None:
    out = gates.judge(check(), {"status": "ok", "rel_error": {"restitution": 0.001}})
    assert out.mark == gates.PASS and out.engine_version == ""
    assert math.isnan(out.value) and math.isnan(out.reference) and math.isnan(out.wall_s)
    assert gates.judge(check(), {"status": "crashed"}).message == "no value (status crashed: )"


def test_not_comparable_message_is_kept_whole() -> None:
    """Only the separator is trimmed when there is no message: a message ending in a letter
    the trim would take (here "X") is kept whole."""
    out = judge(None, status="unsupported", message="needs DirectX")
    assert out.message == "unsupported: needs DirectX"


@pytest.mark.parametrize("sign", [1.0, -1.0])
def test_a_baseline_exactly_at_the_tolerance_passed(sign: float) -> None:
    c = check(tolerance=0.25)
    assert judge(0.5, base=sign * 0.25, c=c).mark == gates.NEW_FAILURE
    assert judge(0.5, base=math.nextafter(sign * 0.25, sign), c=c).mark == gates.FAIL
    assert judge(0.0, base=sign * 0.25, status=IMPLAUSIBLE, c=c).mark == gates.NEW_FAILURE


# ------------------------------------------------------------------ absolute checks

OBLIQUE = RunKey("mujoco", "oblique", (("angle_deg", 45.0), ("velocity_m_s", 2.0)), "native",
                 1e-6, (("friction", 0.3),))


def oblique_result(value: float, reference: float, metric: str = "contact_point_ratio") -> dict:
    """A result whose relative error is undefined (reference 0), as the suite writes it."""
    rel = (value - reference) / abs(reference) if reference else math.nan
    return {"status": "ok", metric: value, "reference": {metric: reference},
            "rel_error": {metric: rel}, "engine_version": "3.1.0", "wall_s": 0.5}


def test_an_absolute_check_judges_engine_minus_reference_where_the_reference_is_zero() -> None:
    """The stick regime's contact-point ratio is 0 in the reference: |engine − reference|
    against the tolerance, signed error in the tables and baseline, its drift by the band."""
    c = gates.Check(OBLIQUE, "contact_point_ratio", 0.001, absolute=True)
    ok = gates.judge(c, oblique_result(2.5e-4, 0.0))
    assert ok.mark == gates.PASS and ok.rel_error == 2.5e-4
    bad = gates.judge(c, oblique_result(-0.98, 0.0))
    assert bad.mark == gates.FAIL and bad.message == "|error| 0.98 > tolerance 0.001"
    moved = gates.judge(c, oblique_result(5e-4, 0.0), {c.id: {"rel_error": 2.5e-4}})
    assert moved.mark == gates.WORSE and moved.message.startswith("error +0.0005 moved")
    # a relative check of the same run has no number: it fails
    rel = gates.judge(gates.Check(OBLIQUE, "contact_point_ratio", 0.001),
                      oblique_result(2.5e-4, 0.0))
    assert rel.mark == gates.FAIL and rel.message.startswith("no value")


def test_regime_with_abs_tolerance_zero_passes_only_when_equal() -> None:
    c = gates.Check(OBLIQUE, "regime", 0.0, absolute=True)
    assert gates.judge(c, oblique_result(0.0, 0.0, "regime")).mark == gates.PASS
    assert gates.judge(c, oblique_result(1.0, 1.0, "regime")).mark == gates.PASS
    slid = gates.judge(c, oblique_result(1.0, 0.0, "regime"))
    assert slid.mark == gates.FAIL and slid.message == "|error| 1 > tolerance 0"


GATE = """
[[gate]]
engine = "mujoco"
mode = "native"
scenario = "oblique"
angles_deg = [45.0]
velocities_m_s = [2.0]
timesteps_s = [1e-6]
parameters = {friction = 0.3}
"""


def test_abs_tolerance_parses_into_absolute_checks() -> None:
    f = gates.parse_gates(GATE + "[gate.tolerance]\nrestitution = 0.1\n"
                          "[gate.abs_tolerance]\ncontact_point_ratio = 0.002\nregime = 0\n")
    kinds = {c.metric: (c.tolerance, c.absolute) for c in f.checks}
    assert kinds == {"restitution": (0.1, False), "contact_point_ratio": (0.002, True),
                     "regime": (0.0, True)}
    only = gates.parse_gates(GATE + "[gate.abs_tolerance]\nregime = 0\n")
    assert [(c.metric, c.absolute) for c in only.checks] == [("regime", True)]


@pytest.mark.parametrize("tables, message", [
    ("", "gate 1: tolerance: missing (required in every [[gate]] without abs_tolerance)"),
    ("[gate.tolerance]\nregime = 0.1\n[gate.abs_tolerance]\nregime = 0\n",
     "gate 1: abs_tolerance.regime: also in tolerance; a metric has one tolerance"),
    ("[gate.abs_tolerance]\nregim = 0\n", "gate 1: abs_tolerance key = 'regim': must be one"),
    ("[gate.abs_tolerance]\nregime = -1\n", "gate 1: abs_tolerance.regime = -1"),
])
def test_bad_abs_tolerance_is_one_line(tables: str, message: str) -> None:
    with pytest.raises(ValueError) as err:
        gates.parse_gates(GATE + tables)
    assert message in str(err.value) and "\n" not in str(err.value)


def test_the_oblique_gates_cover_regime_contact_point_and_tangential_force() -> None:
    """Every oblique gate of the project's gate file checks the contact-point ratio, and the
    regime and the peak tangential force unless its comment says why not (#31)."""
    from pathlib import Path

    path = Path(__file__).resolve().parents[2] / "gates.toml"
    text = path.read_text()
    checks = gates.load_gates(path).checks
    by_run: dict[tuple[str, str], set[str]] = {}
    for c in checks:
        if c.run.scenario == "oblique":
            by_run.setdefault((c.run.engine, c.run.mode), set()).add(c.metric)
    assert len(by_run) == 27  # 9 engines × injected, native, tuned
    for (engine, mode), metrics in by_run.items():
        assert "contact_point_ratio" in metrics, (engine, mode)
        comment = text[:text.index(f'engine = "{engine}"\nmode = "{mode}"\nscenario = '
                                   '"oblique"')].rsplit("[[gate]]", 2)[-2]
        for metric, why in (("regime", "regime not gated: it slides at"),
                            ("peak_tangential_force_n", "peak_tangential_force_n not gated")):
            assert metric in metrics or why in comment, (engine, mode, metric)
    assert all(c.absolute == (c.metric in ("regime", "contact_point_ratio")) for c in checks
               if c.run.scenario == "oblique")


def test_every_wide_relative_tolerance_says_why() -> None:
    """A relative tolerance of 50 % or more in the project's gate file has a ``# why:`` line,
    in the comment above its gate or in its section's header (#31): a tolerance that wide
    must be the engine's documented limit, not a number widened until the gate passed."""
    from pathlib import Path

    text = (Path(__file__).resolve().parents[2] / "gates.toml").read_text()
    checks = gates.load_gates(Path(__file__).resolve().parents[2] / "gates.toml").checks
    lines = text.split("\n")
    wide = {c.line for c in checks if not c.absolute and c.tolerance >= 0.5
            and not scenarios.get(c.run.scenario).measured}
    assert wide  # the file has such gates (native contact models)
    missing = []
    for line in sorted(wide):
        i = line - 1  # the gate's [[gate]] line (Check.line is 1-based)
        while not lines[i].startswith("[[gate]]"):
            i -= 1
        above = []
        j = i - 1
        while j >= 0 and (lines[j].startswith("#") or not lines[j].strip()):
            above.append(lines[j])
            j -= 1
        section = next(k for k in range(i, -1, -1) if lines[k].startswith("# ------"))
        header = []
        for k in range(section, len(lines)):
            if not lines[k].startswith("#"):
                break
            header.append(lines[k])
        if not any("why:" in x for x in above + header):
            missing.append(f"gates.toml:{i + 1}")
    assert not missing, missing
