"""CHANGELOG.md: Keep a Changelog's structure, the released version is the package's, the version policy says
what model bundles really do, and the documentation's What's new page is the changelog itself."""

from __future__ import annotations

import datetime as dt
import re
import tomllib
from pathlib import Path

import numpy as np
import pytest

import tzsl
from tzsl.exceptions import ModelBundleError
from tzsl.inference.bundle import BUNDLE_FORMAT_VERSION, BUNDLE_KEY_ENV, load_bundle, save_bundle

REPO = Path(__file__).resolve().parents[1]
CHANGELOG = REPO / "CHANGELOG.md"
WHATS_NEW = REPO / "docs" / "whats_new.md"

#: The change types of Keep a Changelog 1.1.0, in its order.
CHANGE_TYPES = ("Added", "Changed", "Deprecated", "Removed", "Fixed", "Security")
#: The one level-2 section that is not a version: it sits between the title and the first version.
POLICY = "Version policy"
RELEASE = re.compile(r"^## \[(\d+)\.(\d+)\.(\d+)\] - (\d{4}-\d{2}-\d{2})$")
FENCE = re.compile(r"^\s*(```|~~~)")


def _lines() -> list[str]:
    """The changelog's lines outside fenced code."""
    lines, fenced = [], False
    for line in CHANGELOG.read_text(encoding="utf-8").splitlines():
        if FENCE.match(line):
            fenced = not fenced
            continue
        lines.append("" if fenced else line)
    return lines


def _sections(level: int, lines: list[str]) -> list[tuple[str, list[str]]]:
    """(heading text, body lines) of every heading of exactly ``level`` in ``lines``."""
    marker = "#" * level + " "
    sections: list[tuple[str, list[str]]] = []
    for line in lines:
        if line.startswith(marker):
            sections.append((line[len(marker):].strip(), []))
        elif sections:
            sections[-1][1].append(line)
    return sections


def _versions() -> list[tuple[str, list[str]]]:
    """(heading, body) of ``## [Unreleased]`` and of every released version, in file order."""
    return [(title, body) for title, body in _sections(2, _lines()) if title != POLICY]


def _releases() -> list[tuple[tuple[int, int, int], dt.date]]:
    releases = []
    for title, _ in _versions()[1:]:
        match = RELEASE.match(f"## {title}")
        assert match, f"'## {title}' is not '## [X.Y.Z] - YYYY-MM-DD'"
        major, minor, patch, date = match.groups()
        releases.append(((int(major), int(minor), int(patch)), dt.date.fromisoformat(date)))
    return releases


def _policy() -> str:
    (body,) = [body for title, body in _sections(2, _lines()) if title == POLICY]
    return " ".join(" ".join(body).split())


def test_title_then_policy_then_unreleased_then_releases():
    lines = _lines()
    assert lines[0] == "# Changelog"
    assert [line for line in lines if line.startswith("# ")] == ["# Changelog"], "one title only"
    level2 = [line for line in lines if line.startswith("## ")]
    assert level2[:2] == [f"## {POLICY}", "## [Unreleased]"], level2[:2]
    assert len(level2) > 2, "no released version"
    for line in level2[2:]:
        assert RELEASE.match(line), f"{line!r} is not '## [X.Y.Z] - YYYY-MM-DD'"


def test_releases_are_newest_first_with_real_dates():
    releases = _releases()
    versions = [version for version, _ in releases]
    dates = [date for _, date in releases]
    assert versions == sorted(versions, reverse=True) and len(set(versions)) == len(versions), versions
    assert dates == sorted(dates, reverse=True), dates


def test_versions_hold_only_keep_a_changelog_change_types():
    for title, body in _versions():
        subsections = _sections(3, body)
        names = [name for name, _ in subsections]
        assert names, f"{title}: no change type"
        assert set(names) <= set(CHANGE_TYPES), f"{title}: {sorted(set(names) - set(CHANGE_TYPES))}"
        assert names == sorted(set(names), key=CHANGE_TYPES.index), f"{title}: {names} out of order or repeated"
        before_first = body[:body.index(f"### {names[0]}")]
        assert not any(line.startswith("#### ") for line in before_first), f"{title}: '####' outside a change type"
        for name, entries in subsections:
            assert any(line.startswith("- ") for line in entries), f"{title} / {name}: no entry"
            assert not any(line.startswith("##### ") for line in entries), f"{title} / {name}: heading too deep"


def test_newest_release_is_the_package_version():
    (newest, _), *_ = _releases()
    assert ".".join(map(str, newest)) == tzsl.__version__
    pyproject = tomllib.loads((REPO / "pyproject.toml").read_text(encoding="utf-8"))
    assert pyproject["project"]["version"] == tzsl.__version__


def test_relative_links_point_at_documentation_pages():
    """The changelog is read on its own and inside the docs: a relative link must be a docs/ page."""
    links = re.findall(r"\]\(([^)\s]+)\)", "\n".join(_lines()))
    relative = [link for link in links if not re.match(r"^[a-z]+://", link)]
    assert relative, "expected links into the documentation"
    for link in relative:
        path, _, anchor = link.partition("#")
        assert path.startswith("docs/") and path.endswith(".md"), f"{link}: not a page of docs/"
        assert (REPO / path).is_file(), f"{link}: no such page"
        if anchor:
            headings = re.findall(r"^#{1,3} (.+)$", (REPO / path).read_text(encoding="utf-8"), flags=re.M)
            slugs = {re.sub(r"[^\w\- ]", "", heading.lower()).strip().replace(" ", "-") for heading in headings}
            assert anchor in slugs, f"{link}: no such section"


# ----------------------------------------------------------------------------- the policy against the code
@pytest.fixture
def write_bundle(tmp_path, monkeypatch):
    """Write a tiny bundle as if by tzsl ``version``; return its path."""
    monkeypatch.delenv(BUNDLE_KEY_ENV, raising=False)

    def write(version: str) -> Path:
        with monkeypatch.context() as patch:
            patch.setattr(tzsl, "__version__", version)
            return save_bundle(tmp_path / f"{version}.tzsl", {"w": np.arange(3.0)}, kind="changelog-test")

    return write


def _other(part: int) -> str:
    """The package version with ``part`` (0 major, 1 minor, 2 patch) raised by one."""
    numbers = [int(n) for n in tzsl.__version__.split(".")[:3]]
    numbers[part] += 1
    return ".".join(map(str, numbers[: part + 1] + [0] * (2 - part)))


def test_policy_states_the_bundle_rule():
    policy = _policy()
    for word in ("PATCH", "MINOR", "MAJOR", "major.minor", "retrain", "tzsl_version", "load_bundle"):
        assert word in policy, word
    assert f"`format_version`, now {BUNDLE_FORMAT_VERSION}" in policy
    assert "The PATCH number is not compared" in policy


@pytest.mark.parametrize("part", [0, 1], ids=["major", "minor"])
def test_a_bundle_of_another_major_or_minor_version_is_refused_as_the_policy_quotes(write_bundle, part):
    path = write_bundle(_other(part))
    with pytest.raises(ModelBundleError) as refused:
        load_bundle(path)
    message = str(refused.value)
    assert message.startswith(f"{path}: ")
    quoted = re.search(r'"(bundle written by tzsl X, this is tzsl Y;[^"]+)"', _policy())
    assert quoted, "the policy quotes the refusal"
    expected = quoted.group(1).replace("tzsl X", f"tzsl {_other(part)}").replace("tzsl Y", f"tzsl {tzsl.__version__}")
    assert message[len(f"{path}: "):] == expected


def test_a_bundle_of_another_patch_version_loads(write_bundle):
    arrays, metadata = load_bundle(write_bundle(_other(2)))
    np.testing.assert_array_equal(arrays["w"], np.arange(3.0))
    assert metadata["bundle"]["tzsl_version"] == _other(2)


# ----------------------------------------------------------------------------- the documentation's page
def test_whats_new_is_the_changelog_included():
    """docs/whats_new.md has its title and the include of CHANGELOG.md, nothing written by hand."""
    text = WHATS_NEW.read_text(encoding="utf-8")
    without_comments = re.sub(r"<!--.*?-->", "", text, flags=re.S)
    include = re.search(r"^```\{include\} (\S+)\n((?::[\w-]+:.*\n)*)```$", without_comments, flags=re.M)
    assert include, "docs/whats_new.md does not include a file"
    assert (WHATS_NEW.parent / include.group(1)).resolve() == CHANGELOG
    options = dict(re.findall(r"^:([\w-]+):\s*(.*)$", include.group(2), flags=re.M))
    start = int(options.get("start-line", 0))
    assert CHANGELOG.read_text(encoding="utf-8").splitlines()[:start] == ["# Changelog"][:start], \
        "the include skips more than the changelog's title"
    rest = without_comments.replace(include.group(0), "")
    assert [line for line in rest.splitlines() if line.strip()] == ["# What's new"], \
        "docs/whats_new.md holds text of its own: write it in CHANGELOG.md"


def test_whats_new_is_in_the_documentation_toctree():
    index = (REPO / "docs" / "index.md").read_text(encoding="utf-8")
    toctree = re.search(r"```\{toctree\}\n(.*?)```", index, flags=re.S)
    assert toctree and "whats_new" in toctree.group(1).split()
