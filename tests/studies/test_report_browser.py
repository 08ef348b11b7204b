"""The report as a reader sees it: headless Chromium lays it out; no table overflows, every figure loads.

Skipped where ``chromium`` is not installed (Debian package ``chromium``; CI installs it).
The page itself has no script: the test appends one small inline script to a copy of the page that
opens every <details>, measures each table against its box and the page, checks each <img>, and
writes the measurements into the DOM, which ``chromium --headless --dump-dom`` prints.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import tempfile
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402
import pytest  # noqa: E402

from tzsl.reporting.report import write_report  # noqa: E402

CHROMIUM = shutil.which("chromium") or shutil.which("chromium-browser")
if CHROMIUM is None and os.environ.get("CI"):
    pytest.fail("headless Chromium is missing under CI: `make test` installs Debian's chromium", pytrace=False)
pytestmark = pytest.mark.skipif(CHROMIUM is None, reason="headless Chromium not installed (apt-get install chromium)")

WIDTH = 1280

MEASURE = """
<script>
window.addEventListener("load", () => {
  document.querySelectorAll("details").forEach(d => { d.open = true; });
  const page = document.documentElement.clientWidth;
  const tables = [...document.querySelectorAll("table")].map(t => {
    const box = t.parentElement;
    return {id: t.id, width: t.scrollWidth, box: box.clientWidth, right: t.getBoundingClientRect().right};
  });
  const images = [...document.querySelectorAll("img")].map(i => ({
    alt: i.alt, complete: i.complete, natural: i.naturalWidth, right: i.getBoundingClientRect().right}));
  const out = document.createElement("pre");
  out.id = "measurements";
  out.textContent = JSON.stringify({page, scroll: document.documentElement.scrollWidth, tables, images});
  document.body.appendChild(out);
});
</script>
"""


def measure(report: Path, width: int = WIDTH) -> dict:
    """Layout measurements of ``report`` in headless Chromium at ``width`` CSS pixels."""
    page = report.read_text(encoding="utf-8").replace("</body>", MEASURE + "</body>")
    with tempfile.TemporaryDirectory() as tmp:
        probe = Path(tmp) / "probe.html"
        probe.write_text(page, encoding="utf-8")
        done = subprocess.run(
            [CHROMIUM, "--headless", "--no-sandbox", "--disable-gpu", "--no-first-run",
             "--disable-background-networking", "--disable-component-update", "--disable-sync",
             f"--user-data-dir={tmp}/profile", f"--window-size={width},2000", "--virtual-time-budget=10000",
             "--dump-dom", probe.as_uri()],
            capture_output=True, text=True, timeout=120,
        )
    found = re.search(r'<pre id="measurements">(.*?)</pre>', done.stdout, re.S)
    assert found, f"no measurements from chromium (rc {done.returncode}): {done.stderr[-2000:]}"
    return json.loads(found.group(1).replace("&amp;", "&").replace("&lt;", "<").replace("&gt;", ">")
                      .replace("&quot;", '"'))


def _figure(path: Path, value: float, size=(6, 4)) -> None:
    fig, ax = plt.subplots(figsize=size)
    ax.plot([0, 1], [0, value])
    fig.savefig(path, format="png", dpi=100)
    plt.close(fig)


@pytest.fixture
def results(tmp_path) -> Path:
    """A folder shaped like `make reproduce-tables` output, with the widest tables it writes."""
    root = tmp_path / "results"
    root.mkdir()
    rng = np.random.default_rng(0)
    splits = ["1", "2", "3", "4", "5", "mean", "std"]
    t3 = {"split": splits, "n_test_objects": [11, 7, 7, 10, 11, np.nan, np.nan]}
    for method in ("maxdap", "avgdap"):
        t3[method] = rng.random(7)
        t3[f"{method}_ci95_low"] = t3[method] - 0.1
        t3[f"{method}_ci95_high"] = t3[method] + 0.1
        t3[f"paper_{method}"] = rng.random(7)
    t3.update(chance=1 / 7, majority=0.2, control=0.11)
    pd.DataFrame(t3).to_csv(root / "table3_challenging.csv", index=False)
    attributes = [f"attribute_with_a_long_name_{i}" for i in range(19)]
    wide = pd.DataFrame(rng.random((60, 19)), columns=attributes).assign(split=np.repeat(range(5), 12))
    wide.to_csv(root / "attribute_accuracy_per_split.csv", index=False)
    pd.DataFrame({"method": ["LDAP", "DF-MDAP (T=3)"], "accuracy": [0.5, 0.6], "data": "simulated"}
                 ).to_csv(root / "hand_table5.csv", index=False)
    _figure(root / "object_map.png", 1.0)
    _figure(root / "attribute_accuracy.png", 2.0, size=(12, 4))
    _figure(root / "hand_multigrasp_T.png", 3.0)
    (root / "manifest.json").write_text(json.dumps({"config": {"hand_data": "simulated"}, "command": "x" * 300}))
    write_report(root)
    return root / "report.html"


@pytest.mark.slow
@pytest.mark.parametrize("width", [WIDTH, 1024])
def test_no_table_overflows_and_every_figure_loads(results, width):
    """On a desktop or laptop window, every table fits: nothing to scroll, nothing cut off."""
    m = measure(results, width)
    assert m["scroll"] <= m["page"], f"the page scrolls sideways: {m['scroll']} > {m['page']} px"
    assert len(m["tables"]) == 3 and len(m["images"]) == 3
    for t in m["tables"]:
        assert t["width"] <= t["box"] + 1, f"table {t['id']} is {t['width']} px wide in a {t['box']} px box"
        assert t["right"] <= m["page"] + 1, f"table {t['id']} runs off the page ({t['right']} > {m['page']})"
    for img in m["images"]:
        assert img["complete"] and img["natural"] > 0, f"figure {img['alt']} did not load"
        assert img["right"] <= m["page"] + 1, f"figure {img['alt']} runs off the page"


@pytest.mark.slow
def test_narrow_window_scrolls_wide_tables_in_their_box_not_the_page(results):
    m = measure(results, 640)
    assert m["scroll"] <= m["page"], f"the page scrolls sideways: {m['scroll']} > {m['page']} px"
    assert all(img["right"] <= m["page"] + 1 for img in m["images"])
