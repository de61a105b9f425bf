"""``impactbench reference bounce``: the ball dropped on the plate, bouncing to rest.

Solves :mod:`impactbench.reference.bounce` (Hunt–Crossley contacts integrated with gravity,
exact flights) from drop height ``--height`` (m; repeat or a comma list for several).
``--json`` prints one object per height (a list for several) with ``height_m``, the scalar
metrics (``first_apex_m``, ``bounces_above_1mm``, ``last_bounce_time_s``, ``rest_sink_m``,
``rest_jitter_m_s``), the sequences (``apex_heights_m``, first bounce first;
``impact_speeds_m_s``, ``rebound_speeds_m_s``, ``contact_durations_s``, ``impact_times_s``),
``static_sink_m``, ``status`` and ``message``.
"""

from __future__ import annotations

import argparse
from typing import Any

from impactbench.cliutil import number_list, print_json

HELP = "the ball dropped on the plate, bouncing to rest: Hunt–Crossley with gravity"


def register(top: argparse._SubParsersAction, groups: dict) -> None:
    from impactbench.flags import add_parameter_flags

    p = groups["reference"].add_parser("bounce", help=HELP, description=HELP + ".")
    add_parameter_flags(p, "bounce")
    p.set_defaults(height_m=None)
    p.add_argument("--heights", type=number_list, action="extend", dest="heights",
                   metavar="H", help="several drop heights (m), comma list (beside --height)")
    p.add_argument("--json", action="store_true",
                   help="print JSON (one object, or a list for several heights)")
    p.set_defaults(func=reference_main)


def _point(spec: Any, scenario: Any) -> dict[str, Any]:
    out = spec.reference_metrics(scenario)
    return {"height_m": scenario.height_m, **out, "status": "ok", "message": ""}


def _text(p: dict[str, Any]) -> str:
    apexes = ", ".join(f"{a * 1e3:.4g}" for a in p["apex_heights_m"][:8])
    return (f"h = {p['height_m']:g} m: first apexes (mm) {apexes}; "
            f"{p['bounces_above_1mm']} bounces above 1 mm, the last leaving at "
            f"{p['last_bounce_time_s']:.4g} s; static sink {p['static_sink_m']:.4g} m")


def reference_main(args: argparse.Namespace) -> int:
    from impactbench.flags import scenario_from_args
    from impactbench.scenarios import get

    spec = get("bounce")
    heights = [*([args.height_m] if args.height_m is not None else []), *(args.heights or [])]
    scenarios = [scenario_from_args("bounce", args, height_m=h) for h in heights] \
        or [scenario_from_args("bounce", args)]
    points = [_point(spec, s) for s in scenarios]
    if args.json:
        print_json(points[0] if len(points) == 1 else points)
    else:
        for p in points:
            print(_text(p))
    return 0
