"""The HTML report as a reader sees it: rendered in headless Chromium at 1400 px.

Needs Debian's ``chromium`` (``.ci/run`` installs it); skipped with the command otherwise.
Chromium runs fully offline (no first-run, sync, component updates or background networking).
"""

from __future__ import annotations

import html
import json
import re
import shutil
import subprocess
from pathlib import Path

import pytest

from impactbench import report

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
pytestmark = pytest.mark.skipif(
    CHROMIUM is None, reason="chromium not installed: run `apt-get update && apt-get install -y "
    "chromium`")

PROBE = """<script>
window.addEventListener("load", () => {
  const doc = document.documentElement;
  const imgs = [...document.images];
  const result = {
    images: imgs.length,
    broken: imgs.filter(i => !(i.complete && i.naturalWidth > 0)).map(i => i.getAttribute("src")),
    scrollWidth: doc.scrollWidth, clientWidth: doc.clientWidth,
    scrolledTables: [...document.querySelectorAll("div.table")]
      .filter(d => d.scrollWidth > d.clientWidth + 1).map(d => d.textContent.slice(0, 60)),
    deadAnchors: [...document.querySelectorAll('a[href^="#"]')]
      .map(a => a.getAttribute("href").slice(1)).filter(id => !document.getElementById(id)),
    headings: [...document.querySelectorAll("main h2")].map(h => h.textContent),
  };
  const out = document.createElement("pre");
  out.id = "probe";
  out.textContent = JSON.stringify(result);
  document.body.appendChild(out);
});
</script>"""


def browse(page: Path, profile: Path, width: int = 1400) -> dict:
    """Load ``page`` in headless Chromium; the probe's findings as a dict."""
    probe = page.with_name("probe_" + page.name)
    probe.write_text(page.read_text().replace("</body>", PROBE + "</body>"))
    cmd = [CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic",
           "--no-first-run", "--disable-background-networking", "--disable-component-update",
           "--disable-sync", "--hide-scrollbars", f"--user-data-dir={profile}",
           f"--window-size={width},900", "--virtual-time-budget=10000", "--dump-dom",
           probe.as_uri()]
    dom = subprocess.run(cmd, capture_output=True, text=True, timeout=120, check=True).stdout
    found = re.search(r'<pre id="probe">(.*?)</pre>', dom, re.S)
    assert found, f"the probe did not run; Chromium printed: {dom[:300]!r}"
    return json.loads(html.unescape(found.group(1)))


@pytest.fixture(scope="module")
def seen(small_report: report.Report, tmp_path_factory: pytest.TempPathFactory) -> dict:
    return browse(small_report.out_dir / "index.html", tmp_path_factory.mktemp("chromium"))


def test_every_image_loads(seen: dict, small_report: report.Report) -> None:
    assert seen["broken"] == []
    assert seen["images"] >= len(list((small_report.out_dir / "figures").glob("report_*.png")))


def test_no_horizontal_overflow_at_1400_px(seen: dict) -> None:
    assert seen["scrollWidth"] <= seen["clientWidth"] == 1400
    assert seen["scrolledTables"] == []


def test_navigation_and_how_to_read_are_there(seen: dict) -> None:
    assert seen["deadAnchors"] == []
    assert seen["headings"][:2] == ["Scoreboard", "How to read it"]
    assert {"Failed runs", "Physical parameters", "Index of figures"} <= set(seen["headings"])
