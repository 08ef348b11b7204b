"""No measured number typed by hand in the README, the docs, the benchmark READMEs or docstrings."""

from __future__ import annotations

from pathlib import Path

from tzsl.reporting.readme_results import BEGIN, END
from tzsl.reporting.typed_numbers import ALLOWED, main, scan, scanned_files

REPO = Path(__file__).resolve().parent.parent


def test_no_typed_measured_number_outside_generated_blocks():
    findings = scan(REPO)
    assert not findings, "typed numbers (generate them with `make numbers` or remove them):\n" + "\n".join(
        map(str, findings))


def test_every_allowed_fragment_is_still_there_and_has_a_reason():
    texts = {str(p): (REPO / p).read_text(encoding="utf-8") for p in scanned_files(REPO)}
    stale = [key for key in ALLOWED if key[1] not in texts.get(key[0], "")]
    assert not stale, f"allow-list entries that no longer match: {stale}"
    assert all(reason.strip() for reason in ALLOWED.values())


def test_scanner_finds_planted_numbers_and_skips_blocks_code_and_definitions(tmp_path, capsys):
    (tmp_path / "docs").mkdir()
    (tmp_path / "tzsl").mkdir()
    (tmp_path / "README.md").write_text(
        f"# t\n\nAVGDAP reaches 0.31 here.\n\n{BEGIN}\n| x | 0.310 [0.2, 0.4] |\n{END}\n\n"
        "```bash\ntzsl run --alpha 0.05\n```\n\n    indented 0.123\n\nA 95% interval; inline `0.25` is a value.\n")
    (tmp_path / "docs" / "page.md").write_text("The ensemble gains +0.097 [+0.03, +0.10].\nIt is 4x slower.\n"
                                              "About 92% of fits.\nEach fit takes 6 s.\n")
    (tmp_path / "tzsl" / "m.py").write_text(
        '"""Module.\n\nExact 0.310 vs approximate 0.264.\n"""\n\nx = 0.125  # speeds up 10x\n'
        'def f(a=0.05):\n    """One.\n\n    a : float, default 0.05\n    >>> f(0.333)\n    """\n')
    found = {(f.path, f.line, f.kind) for f in scan(tmp_path)}
    assert found == {("README.md", 3, "decimal"), ("docs/page.md", 1, "decimal"), ("docs/page.md", 2, "speed-up"),
                     ("docs/page.md", 3, "percentage"), ("docs/page.md", 4, "duration"), ("tzsl/m.py", 3, "decimal"),
                     ("tzsl/m.py", 6, "speed-up")}
    assert main([str(tmp_path)]) == 1
    assert "docs/page.md:2: speed-up" in capsys.readouterr().out


def test_what_a_docs_build_writes_from_the_code_is_not_scanned(tmp_path):
    """docs/_generated (registry tables, API stubs) exists only after a docs build: scanning it made the
    check depend on whether the build ran first in the same test run (a dataset's source string, an arXiv id)."""
    for folder in ("_generated", "_build", "auto_examples"):
        (tmp_path / "docs" / folder).mkdir(parents=True)
        (tmp_path / "docs" / folder / "table.md").write_text("The ensemble gains +0.097 [+0.03, +0.10].\n")
    (tmp_path / "docs" / "page.md").write_text("The ensemble gains +0.097 [+0.03, +0.10].\n")
    assert [f.path for f in scan(tmp_path)] == ["docs/page.md"]
