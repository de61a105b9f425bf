"""The report's contact-model section: the exact nominal-vs-effective restitution table."""

from __future__ import annotations

from impactbench.reference.models import MODELS
from impactbench.reference.zoo import effective_restitution

from impactbench import report


def test_report_has_the_contact_model_table_and_figure(small_report: report.Report) -> None:
    text = (small_report.out_dir / "README.md").read_text()
    assert "## Contact models: nominal against effective restitution" in text
    section = text.split("## Contact models", 1)[1].split("\n## ", 1)[0]
    for model in MODELS:
        line = next(row for row in section.splitlines() if row.startswith(f"| `{model}` |"))
        assert f"{effective_restitution(model, 0.5):.4f}" in line
    assert "This report's ball uses `hunt-crossley`" in section
    assert (small_report.out_dir / "figures" / "report_zoo_restitution.png").stat().st_size > 0
    assert "report_zoo_restitution.png" in (small_report.out_dir / "index.html").read_text()
