"""tzsl report: one valid, self-contained HTML page with every table, figure and manifest."""

from __future__ import annotations

import base64
import json
from html.parser import HTMLParser
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
import pandas as pd
import pytest

from tzsl import __version__
from tzsl.exceptions import ConfigError, DataFileError
from tzsl.reporting.report import render_report, write_report
from tzsl.reporting.tables import FOLD_ROWS

VOID = {"area", "base", "br", "col", "embed", "hr", "img", "input", "link", "meta", "source", "track", "wbr"}


class PageChecker(HTMLParser):
    """Balanced tags, tables by id, images and <details> blocks."""

    def __init__(self) -> None:
        super().__init__(convert_charrefs=True)
        self.stack: list[str] = []
        self.errors: list[str] = []
        self.tables: list[str] = []
        self.images: list[dict] = []
        self.external: list[str] = []
        self.details = 0
        self.text: list[str] = []

    def handle_starttag(self, tag, attrs):
        attrs = dict(attrs)
        if tag == "img":
            self.images.append(attrs)
        if tag == "table":
            self.tables.append(attrs.get("id", ""))
        if tag == "details":
            self.details += 1
        if tag in ("script", "link") or (tag == "img" and not attrs.get("src", "").startswith("data:")):
            self.external.append(tag)
        if tag not in VOID:
            self.stack.append(tag)

    def handle_startendtag(self, tag, attrs):
        self.handle_starttag(tag, attrs)
        if tag not in VOID:
            self.stack.pop()

    def handle_endtag(self, tag):
        if tag in VOID:
            return
        if not self.stack or self.stack[-1] != tag:
            self.errors.append(f"</{tag}> closes <{self.stack[-1] if self.stack else None}>")
            return
        self.stack.pop()

    def handle_data(self, data):
        self.text.append(data)


def _parse(page: str) -> PageChecker:
    checker = PageChecker()
    checker.feed(page)
    checker.close()
    return checker


def _figure(path: Path, value: float) -> None:
    fig, ax = plt.subplots(figsize=(2, 2))
    ax.plot([0, 1], [0, value])
    fig.savefig(path, format="png", dpi=40)
    plt.close(fig)


@pytest.fixture
def results(tmp_path) -> Path:
    root = tmp_path / "results"
    (root / "fabric").mkdir(parents=True)
    pd.DataFrame({"split": ["1", "2", "mean"], "maxdap": [0.3, 0.4, 0.35], "avgdap": [0.31, 0.42, 0.365],
                  "paper_maxdap": [np.nan, np.nan, 0.39], "paper_avgdap": [np.nan, np.nan, 0.41]}
                 ).to_csv(root / "table1_fusion.csv", index=False)
    pd.DataFrame({"attribute": [f"a{i}" for i in range(FOLD_ROWS + 5)], "accuracy": 0.5}
                 ).to_csv(root / "attribute_accuracy_per_split.csv", index=False)
    pd.DataFrame({"method": ["<script>alert(1)</script>"], "accuracy": [1.0]}
                 ).to_csv(root / "fabric" / "fabric_table1.csv", index=False)
    _figure(root / "attribute_sweep.png", 1.0)
    _figure(root / "fabric" / "fabric_lambda.png", 2.0)
    (root / "manifest.json").write_text(json.dumps({"config": {"seed": 0, "note": "a < b & c"}}))
    (root / "fabric" / "fabric_manifest.json").write_text(json.dumps({"study": "fabric"}))
    (root / ".hidden").mkdir()
    pd.DataFrame({"x": [1]}).to_csv(root / ".hidden" / "skip.csv", index=False)
    return root


def test_report_is_valid_html_with_every_table_figure_and_manifest(results):
    path = write_report(results)
    assert path == results / "report.html"
    page = path.read_text(encoding="utf-8")
    checker = _parse(page)
    assert checker.errors == []
    assert checker.stack == []
    assert not checker.external  # self-contained: no scripts, style sheets or linked images
    # every CSV is a table, hidden folders skipped
    assert len(checker.tables) == 3
    for name in ("table1_fusion.csv", "attribute_accuracy_per_split.csv", "fabric/fabric_table1.csv"):
        assert name in page
    assert "skip.csv" not in page
    # every PNG embedded byte for byte
    embedded = [base64.b64decode(img["src"].split(",", 1)[1]) for img in checker.images]
    assert len(embedded) == 2
    assert (results / "attribute_sweep.png").read_bytes() in embedded
    assert (results / "fabric" / "fabric_lambda.png").read_bytes() in embedded
    assert all(img["src"].startswith("data:image/png;base64,") for img in checker.images)
    # manifests (collapsible) and the long table folded; text escaped, not interpreted
    assert checker.details == 3
    text = "".join(checker.text)
    assert '"note": "a < b & c"' in text and '"study": "fabric"' in text
    assert "<script>alert(1)</script>" in text
    assert f"tzsl {__version__}" in text
    # Table 1 first (sections in paper order), ours beside the paper's in one cell
    assert page.index("table1_fusion.csv") < page.index("attribute_accuracy_per_split.csv")
    assert "<th>maxdap [paper]</th>" in page and "paper_maxdap" not in page
    assert "<td>0.350 [0.390]</td>" in page and "<td>0.300</td>" in page


def test_report_refuses_overwrite_and_writes_atomically(results, tmp_path):
    out = tmp_path / "page.html"
    write_report(results, out=out)
    with pytest.raises(ConfigError, match="already exists"):
        write_report(results, out=out)
    write_report(results, out=out, force=True)
    assert not list(tmp_path.glob(".page.html.*"))
    # a report inside the folder does not report itself
    write_report(results)
    page = write_report(results, force=True).read_text()
    assert page.count("<table") == 3 and "report.html</a>" not in page


def test_report_of_missing_or_empty_folder(tmp_path):
    with pytest.raises(DataFileError, match="not found"):
        render_report(tmp_path / "nope")
    (tmp_path / "empty").mkdir()
    with pytest.raises(DataFileError, match="no CSV table"):
        render_report(tmp_path / "empty")


def test_table_view_merges_paper_and_interval_columns_and_prints_counts_whole():
    from tzsl.reporting.tables import table_view

    table = pd.DataFrame({
        "method": ["DAP", "ESZSL"], "n_objects": [10.0, 18.0], "accuracy": [0.31, 0.25],
        "ci95_low": [0.25, 0.2], "ci95_high": [0.37, 0.3], "paper_accuracy": [0.35, np.nan],
        "avgdap": [0.4, 0.5], "avgdap_ci95_low": [0.3, 0.4], "avgdap_ci95_high": [0.5, 0.6], "chance": 0.1,
    })
    view = table_view(table)
    assert view["header"] == ["method", "n_objects", "accuracy (95% CI) [paper]", "avgdap (95% CI)", "chance"]
    assert view["rows"][0] == ["DAP", "10", "0.310 (0.250\u20130.370) [0.350]", "0.400 (0.300\u20130.500)", "0.100"]
    assert view["rows"][1][2] == "0.250 (0.200\u20130.300)"  # no paper number: nothing in brackets


def test_sections_banner_deviations_and_other_results(tmp_path):
    root = tmp_path / "res"
    root.mkdir()
    pd.DataFrame({"method": ["LDAP"], "accuracy": [0.5], "data": ["simulated"]}).to_csv(root / "hand_table5.csv",
                                                                                       index=False)
    pd.DataFrame({"lam": [0, 1], "acc": [0.4, 0.5]}).to_csv(root / "fabric_table1.csv", index=False)
    pd.DataFrame({"x": [1, 2]}).to_csv(root / "my_extra.csv", index=False)
    _figure(root / "fabric_lambda.png", 1.0)
    (root / "manifest.json").write_text(json.dumps({
        "config": {"study": "phac2-dap", "svm_params": {"cv": 5}, "hand_data": "simulated",
                   "dap_settings": {"splits": {"random_min_train_positives": 2, "n_splits": 20}}},
        "data_files": {"/data/phac2.h5": "ab" * 32}, "packages": {"numpy": "2.0"}}))
    page = render_report(root)
    checker = _parse(page)
    assert checker.errors == [] and checker.stack == []
    text = " ".join("".join(checker.text).split())
    assert "SIMULATED DATA" in text and page.count('class="simulated"') == 1
    # fabric figure beside its table, in the fabric section, before the hand section
    fabric = page.index('id="fabric-table1"')
    assert fabric < page.index("fabric_lambda.png") < page.index('id="hand-table5"')
    assert page.index('id="other"') > page.index('id="hand-table5"') and "my_extra.csv" in page
    assert "5-fold object-grouped cross-validation" in text
    assert "n_splits = 20 (paper: 5)" in text and "SIMULATED grasps" in text
    assert "fewer than 2 positive training objects" in text
    assert "/data/phac2.h5" in text and "numpy 2.0" in text and "1 file(s) read" in text
    assert page.index('id="deviations"') < page.index('id="provenance"')


def test_no_banner_without_simulated_evidence_outside_the_hand_section(tmp_path):
    root = tmp_path / "res"
    root.mkdir()
    pd.DataFrame({"split": ["1"], "avgdap": [0.3]}).to_csv(root / "table1_fusion.csv", index=False)
    assert 'class="simulated"' not in render_report(root)


def test_counts_text_and_transposed_wide_short_tables():
    from tzsl.reporting.tables import TRANSPOSE_COLUMNS, table_view

    table = pd.DataFrame({"split": ["1", "2", "mean"], "n_attributes": [18.0, 19.0, 18.5],
                          "excluded": ["bumpy;hairy", np.nan, np.nan], "avgdap": [0.3, 0.4, 0.35]})
    view = table_view(table)
    assert [row[1] for row in view["rows"]] == ["18", "19", "18.5"]  # a count; its mean with one decimal
    assert view["rows"][0][2] == "bumpy; hairy" and view["classes"][2] == "text"
    wide = pd.DataFrame({"condition": ["seq", "img"], "config": [1, 2],
                         **{f"m{i}": [0.1 * i, 0.2] for i in range(TRANSPOSE_COLUMNS)}})
    view = table_view(wide)
    assert view["transposed"] and view["header"] == ["column", "seq / 1", "img / 2"]
    assert view["rows"][0] == ["m0", "0.000", "0.200"] and view["n_rows"] == TRANSPOSE_COLUMNS


def test_active_touch_section_table_with_intervals_and_figure_beside(tmp_path):
    root = tmp_path / "res"
    root.mkdir()
    summary = pd.DataFrame({"split_kind": ["random", "random"], "strategy": ["active", "chance"],
                            "acc_1ep": [0.29, 0.1], "acc_1ep_ci95_low": [0.25, None], "acc_1ep_ci95_high": [0.33, None],
                            "acc_mean_over_seconds": [0.27, 0.1]})
    summary.to_csv(root / "active_touch.csv", index=False)
    pd.DataFrame({"strategy": ["active"], "threshold": [0.9], "accuracy": [0.36], "accuracy_ci95_low": [0.3],
                  "accuracy_ci95_high": [0.4], "difference": [-0.01], "difference_ci95_low": [-0.02],
                  "difference_ci95_high": [0.0], "eps_saved": [1.3]}).to_csv(root / "active_touch_stop.csv",
                                                                            index=False)
    _figure(root / "active_touch.png", 1.0)
    page = render_report(root)
    section = page[page.index('id="active-touch"'):]
    assert "Other results" not in page and 'class="simulated"' not in page
    pd.DataFrame({"data": ["simulated"], "strategy": ["active"], "grasps": [1], "accuracy": [0.5]}).to_csv(
        root / "active_touch_hand.csv", index=False)
    hand = render_report(root)
    assert hand.count('class="simulated"') == 1 and hand.index('id="active-touch-hand"') < hand.index(
        'class="simulated"')
    assert "<td>0.290 (0.250\u20130.330)</td>" in section and "<td>-0.010 (-0.020\u20130.000)</td>" in section
    # the figure sits in the block of active_touch.csv, beside it (not stacked below)
    block = section[section.index('<div class="pair'):section.index("active_touch_stop.csv")]
    assert "active_touch.png" in block and 'class="pair stacked"' not in block
