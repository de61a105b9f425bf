"""The zoo's nominal-vs-effective restitution figure and table."""

from __future__ import annotations

import pandas as pd
import pytest
from impactbench.reference.models import MODELS
from impactbench.reference.zoo import effective_restitution

from impactbench.figures import zoo


def test_writes_figure_and_table_with_exact_values(tmp_path):
    paths = zoo.write(tmp_path)
    assert {p.name for p in paths} == {"zoo_restitution.png", "zoo_restitution.csv",
                                       "zoo_restitution.md"}
    assert all(p.stat().st_size > 0 for p in paths)
    table = pd.read_csv(tmp_path / "zoo_restitution.csv")
    assert list(table["model"]) == list(MODELS)
    for row in table.itertuples(index=False):
        assert row[table.columns.get_loc("e = 0.5")] == pytest.approx(
            effective_restitution(row.model, 0.5), rel=1e-9)
    assert "Lankarani & Nikravesh" in (tmp_path / "zoo_restitution.md").read_text()
