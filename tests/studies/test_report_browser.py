"""The report as a reader sees it: headless Chromium lays it out; no table overflows, every figure loads.

Two folders: one shaped like `make reproduce-tables` output (the papers), and the results of the
template experiment (experiments/my_dataset_template.toml, made fast) run on a small SIMULATED lab
dataset - 9 objects grasped by the 5 fingers of a hand - whose method table is wide: its key
columns must stay readable (no column squeezed to a letter per line), the rest behind a toggle.

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
import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
import pytest
from click.testing import CliRunner

from tzsl.cli import cli
from tzsl.datasets import write_plain_dataset
from tzsl.reporting.report import write_report

REPO = Path(__file__).resolve().parents[2]

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
    const cells = [...t.querySelectorAll("th, td")];
    const heads = [...t.querySelectorAll("th")].map(h =>
      h.getBoundingClientRect().height / (parseFloat(getComputedStyle(h).fontSize) * 1.4));
    return {id: t.id, cls: t.className, width: t.scrollWidth, box: box.clientWidth,
            right: t.getBoundingClientRect().right, boxRight: box.getBoundingClientRect().right,
            minCell: Math.min(...cells.map(c => c.getBoundingClientRect().width)),
            headLines: Math.max(0, ...heads)};
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


# --------------------------------------------------------------------------- a lab's small dataset

ROWS = {  # hard rough cold soft solid paper
    "mug": [1, 0, 1, 0, 1, 0], "sponge": [0, 1, 0, 1, 1, 0], "can": [1, 0, 1, 0, 1, 0],
    "towel": [0, 1, 0, 1, 1, 0], "stone": [1, 1, 1, 0, 1, 0], "tissue": [0, 0, 0, 1, 1, 1],
    "bottle": [1, 0, 0, 0, 1, 0], "brush": [0, 1, 0, 0, 1, 0], "foam": [0, 0, 0, 1, 0, 0],
}
#: The template made fast: a few quick methods beside DAP, three random splits, a one-point SVM grid.
FAST = """
[methods]
compare = ["eszsl", "sae", "ale", "sje", "devise", "iap"]
sweep = false

[gzsl]
methods = ["dap"]

[splits]
n_splits = 3

[svm]
n_C = 1
n_gamma = 1
n_draws = 1
"""


@pytest.fixture(scope="module")
def lab_report(tmp_path_factory) -> Path:
    """`tzsl run` of the template on 9 SIMULATED objects x 5 fingers (signals follow the attributes), then
    `tzsl report`."""
    root = tmp_path_factory.mktemp("lab")
    classes = pd.DataFrame.from_dict(ROWS, orient="index", columns=["hard", "rough", "cold", "soft", "solid", "paper"])
    classes.index.name = "class"
    rng = np.random.default_rng(0)
    trials, signals = [], []
    for name, row in classes.iterrows():
        level = row.to_numpy(dtype=float)
        for g in range(4):
            trials.append((f"{name}_{g}", name))
            signals.append([np.column_stack([3 * level[0] - 2 * level[3] + rng.normal(0, 0.5, 30),
                                             3 * level[1] + 2 * level[2] + rng.normal(0, 0.5, 30)]) + 0.1 * k
                            for k in range(5)])
    dataset = write_plain_dataset(root / "my_dataset", classes, pd.DataFrame(trials, columns=["trial_id", "class"]),
                                  sensors=[f"finger_{k}" for k in range(5)], signals=signals,
                                  channels=("pressure", "vibration"), signal_format="csv",
                                  settings={"name": "lab-hand", "classes": {"allow_identical_rows": True}})
    template = (REPO / "experiments" / "my_dataset_template.toml").read_text()
    experiment = root / "my_experiment.toml"
    experiment.write_text(template.replace('plain = "my_dataset"', f'plain = "{dataset}"').replace(
        'folder = "results/my_dataset"', f'folder = "{root / "results"}"') + FAST)
    for args in (["run", str(experiment), "--no-progress"], ["report", str(root / "results")]):
        done = CliRunner().invoke(cli, args)
        assert done.exit_code == 0, done.output + done.stderr
    return root / "results" / "report.html"


def _visible_text(page: str) -> str:
    """The page's text before its provenance (the manifests quote the run's files verbatim)."""
    body = page[page.index("<body>"):page.index('<section id="provenance">')]
    return " ".join(re.sub(r"<[^>]+>", " ", body).split())


@pytest.mark.slow
def test_lab_report_speaks_of_the_dataset_not_the_paper(lab_report):
    page = lab_report.read_text(encoding="utf-8")
    text = _visible_text(page)
    assert re.search(r"<title>lab-hand: zero-shot study</title>", page)
    assert "Dataset: lab-hand" in text and "9 (9 with trials, 7 distinct attribute rows)" in text
    assert "5 (finger_0, finger_1, finger_2, finger_3, finger_4)" in text and "36 (per class" in text
    assert text.index("Dataset: lab-hand") < text.index("Summary") < text.index("Contents")
    assert "On random splits the most accurate method is" in text and "against chance 0.200" in text
    assert "What the run relaxed to fit the dataset" in text and "svm.cv: asked 5, used 4" in text
    for paper in ("DAP paper", "PHAC-2", "Deviations from the paper", "[paper]", "Table 1"):
        assert paper not in text, f"{paper!r} in the report of a lab's dataset"
    # the fusion text quotes the test classes per split from table1_fusion.csv, not a constant
    fusion = pd.read_csv(lab_report.parent / "table1_fusion.csv")
    n_test = fusion.loc[fusion["split"].astype(str).str.isdigit(), "n_test_objects"].astype(int).unique()
    assert len(n_test) == 1 and f"3 random splits of {n_test[0]} unseen classes each" in text
    # the method comparison: key columns, every column behind the toggle
    assert "In every row: study = zero-shot; data = lab-hand" in text
    assert re.search(r"all \d+ columns of method_comparison.csv", text)


@pytest.mark.slow
@pytest.mark.parametrize("width", [WIDTH, 1024])
def test_lab_report_key_columns_are_readable_and_nothing_overflows(lab_report, width):
    """Key tables fit their box with readable columns; full tables scroll inside their box, never the page."""
    m = measure(lab_report, width)
    assert m["scroll"] <= m["page"], f"the page scrolls sideways: {m['scroll']} > {m['page']} px"
    key = [t for t in m["tables"] if "key" in t["cls"].split()]
    full = [t for t in m["tables"] if "full" in t["cls"].split()]
    assert key and len(full) == len(key)
    for t in m["tables"]:
        assert t["boxRight"] <= m["page"] + 1, f"table {t['id']}'s box runs off the page"
        if "full" in t["cls"].split():
            continue
        assert t["width"] <= t["box"] + 1, f"table {t['id']} is {t['width']} px wide in a {t['box']} px box"
        assert t["minCell"] >= 30, f"table {t['id']} squeezes a column to {t['minCell']:.0f} px"
        assert t["headLines"] <= 4.5, f"table {t['id']} wraps a header over {t['headLines']:.1f} lines"
    assert m["images"] and all(img["complete"] and img["natural"] > 0 for img in m["images"])
    assert all(img["right"] <= m["page"] + 1 for img in m["images"])
