"""Kharaz, Gorham & Salman (2001): measured oblique impacts of an alumina sphere on glass.

A. H. Kharaz, D. A. Gorham, A. D. Salman, "An experimental study of the elastic rebound of
spheres", Powder Technology 120(3):281–291, 2001, doi:10.1016/S0032-5910(01)00283-2.
Al₂O₃ spheres (R = 2.5 mm) at 3.9 m/s on a thick soda-lime glass anvil, incidence angles
0°–~85° from the normal. The packaged points (``data/kharaz2001/kharaz2001.csv``, its README
beside it gives source and licence) are digitised from the paper's figures, about ±1–2 %
reading error. The simulation inputs the DEM benchmarks use for this experiment (Chung & Ooi
2011, test 4) are :meth:`impactbench.reference.oblique.Oblique.kharaz2001`.

:func:`load` returns a tidy table, one row per point: ``quantity`` (the file's name),
``metric`` (the oblique metric it measures: ``tangential_restitution``, ``spin_out_rad_s`` —
the measured *magnitude* |ω'|, compare with ``abs`` — and ``rebound_angle_deg``),
``angle_deg`` (incidence), ``value`` and ``unit``.
"""

from __future__ import annotations

from functools import cache
from importlib import resources
from io import StringIO

import pandas as pd

DATA = "data/kharaz2001/kharaz2001.csv"
"""The packaged file, relative to the ``impactbench.reference`` package."""

METRIC_OF: dict[str, str] = {
    "tangential_restitution_com": "tangential_restitution",
    "spin_out_abs": "spin_out_rad_s",
    "rebound_angle_com": "rebound_angle_deg",
}
"""The file's quantity → the oblique metric it measures (spin: its magnitude)."""

COLUMNS: tuple[str, ...] = ("quantity", "metric", "angle_deg", "value", "unit")


@cache
def _text() -> str:
    return resources.files("impactbench.reference").joinpath(DATA).read_text()


def load() -> pd.DataFrame:
    """The measured points as a tidy DataFrame (:data:`COLUMNS`), in the file's order."""
    raw = pd.read_csv(StringIO(_text()))
    expected = ["quantity", "incidence_angle_deg", "value", "unit"]
    if list(raw.columns) != expected:
        raise ValueError(f"{DATA}: columns {list(raw.columns)!r}, expected {expected!r}")
    unknown = sorted(set(raw["quantity"]) - set(METRIC_OF))
    if unknown:
        raise ValueError(f"{DATA}: quantity = {unknown[0]!r}: must be one of "
                         f"{', '.join(METRIC_OF)}")
    out = pd.DataFrame({
        "quantity": raw["quantity"].astype(str),
        "metric": raw["quantity"].map(METRIC_OF).astype(str),
        "angle_deg": raw["incidence_angle_deg"].astype(float),
        "value": raw["value"].astype(float),
        "unit": raw["unit"].astype(str),
    })
    return out.loc[:, list(COLUMNS)]


def points(metric: str) -> pd.DataFrame:
    """The points of one metric (``angle_deg``, ``value``), sorted by angle."""
    table = load()
    if metric not in set(table["metric"]):
        raise ValueError(f"metric = {metric!r}: must be one of "
                         f"{', '.join(sorted(set(table['metric'])))}")
    sel = table[table["metric"] == metric].sort_values("angle_deg")
    return sel.loc[:, ["angle_deg", "value"]].reset_index(drop=True)
