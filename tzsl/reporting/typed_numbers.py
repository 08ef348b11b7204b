"""Find measured numbers typed by hand into the README, the docs, the benchmark READMEs and docstrings.

Every accuracy, interval, gain, percentage or timing tzsl publishes is written by
``make numbers`` (:mod:`tzsl.reporting.readme_results`) between generated-block markers, from
the CSVs of the shipped code; nothing is typed. This scanner reads the prose of those files
(Markdown outside fenced code and generated blocks; comments and triple-quoted strings of Python
files) and reports every number that looks measured:

* a decimal with two or more fractional digits (``0.310``, ``+0.097``);
* an interval of decimals (``[0.275, 0.351]``, ``(0.19-0.44)``);
* a percentage (``92%``);
* a duration or a speed-up (``6 s``, ``about 4x``).

Definitions, defaults and the papers' own numbers are told apart by :data:`ALLOWED`, one entry a
line fragment with its reason. ``python -m tzsl.reporting.typed_numbers [ROOT]`` prints each
finding as ``file:line: text`` and exits 1 when there is one (``make numbers-check`` runs it).
"""

from __future__ import annotations

import argparse
import io
import re
import sys
import tokenize
from dataclasses import dataclass
from pathlib import Path

from tzsl.reporting.readme_results import block_spans

__all__ = ["ALLOWED", "DEFINITIONS", "PATTERNS", "Finding", "main", "scan", "scanned_files"]

#: What a measured number looks like in prose.
PATTERNS: dict[str, re.Pattern[str]] = {
    "decimal": re.compile(r"(?<![\w.=/-])[+-]?\d*\.\d{2,}(?![\w.])"),
    "interval": re.compile(r"[\[(]\s*[+-]?\d*\.\d+\s*(?:,|-|–)\s*[+-]?\d*\.\d+\s*[\])]"),
    "percentage": re.compile(r"(?<![\w.])\d+(?:\.\d+)?\s?%"),
    "duration": re.compile(r"(?<![\w.=])\d+(?:\.\d+)?\s?(?:ms|s|seconds?|min|minutes?|hours?)\b(?![-=])"),
    "speed-up": re.compile(r"(?<![\w.=])\d+(?:\.\d+)?x\b|\d+(?:\.\d+)? times (?:faster|slower)"),
}

#: Phrases whose numbers are definitions wherever they stand: the interval level, PCA's kept
#: variance, a 50% prior, defaults, Python's version, doctest lines.
DEFINITIONS = re.compile(r"\b95\s?%|\b50% (?:attribute )?prior|\bdefault\b|Python >= [\d.]+|>>>")

#: ``(file, fragment of the line)`` -> why the number there is not a measurement of tzsl's.
ALLOWED: dict[tuple[str, str], str] = {
    ("examples/plot_3_calibration.py", "about 80% should be right"): "what calibration means (definition)",
    ("tzsl/datasets/_hand_simulator.py", "in [20%, 40%] of the recording"):
        "the simulator's contact window (definition)",
    ("tzsl/datasets/_hand_simulator.py", "first 20% of rows"): "the simulator's baseline rows (definition)",
    ("tzsl/datasets/_phac2_hold_mat.py", "hold the 10 s thermal-hold EP"): "the recording protocol of the data",
    ("tzsl/benchmarks/bench_scale.py", "0.2 s with psutil"): "the benchmark's sampling period (definition)",
    ("tzsl/studies/fabric/study.py", "taken about 10 s apart"): "the recording protocol of the data",
    ("tzsl/studies/hand/study.py", "mostly (> 50%)"): "the definition of 'mostly'",
    ("tzsl/features/_grasp_features.py", "(0.1 s at 100 Hz)"): "the baseline window (definition)",
    ("tzsl/features/_keyframes.py", "10 % onset criterion"): "the onset criterion (definition)",
    ("tzsl/features/_texture.py", "(0.1 at downsample 2 = 0.05 cycles"): "filter frequencies (definition)",
    ("tzsl/features/_texture.py", "dropouts, ~0.4 % of pixels"):
        "a property of the data files that motivates the robust range",
    ("tzsl/features/_texture.py", "ignores up to 1 % outliers"): "the robust range's quantiles (definition)",
    ("tzsl/models/detectors/_attribute_svm.py", "``gamma`` in [0.01, 1] tuned by"):
        "the DAP paper's protocol (citation)",
    ("tzsl/models/detectors/_attribute_svm.py", "gives the decades 1, 10, 100 and 0.01, 0.1, 1"):
        "grid points (definition)",
    ("tzsl/models/detectors/_attribute_svm.py", "(0.001, 0.0001 for the"): "grid points (definition)",
    ("tzsl/models/detectors/_attribute_training.py", "(0.001 and"): "grid points (definition)",
    ("tzsl/models/detectors/_attribute_training.py", "0.0001 for the paper's range"): "grid points (definition)",
    ("tzsl/models/detectors/_attribute_training.py", "edge 0.01, and with about 25"):
        "the grid's edge and PCA's cap (definitions)",
    ("tzsl/models/calibration/_posterior_calibration.py", "T from about 0.007 to 150"):
        "the search bounds of the constant (definition)",
}

#: Where numbers are published (globs relative to the repository root).
SCANNED = ("README.md", "docs/**/*.md", "docs/**/*.py", "examples/*.py", "experiments/**/README*.md", "tzsl/**/*.py")


@dataclass(frozen=True)
class Finding:
    """One number that looks measured: where, the kind of pattern and the line."""

    path: str
    line: int
    kind: str
    text: str

    def __str__(self) -> str:
        return f"{self.path}:{self.line}: {self.kind}: {self.text.strip()}"


def scanned_files(root: Path) -> list[Path]:
    """The files :func:`scan` reads, sorted, relative to ``root``.

    Left out: what a docs build writes from the code (``_build``, the gallery's ``auto_examples``, and
    ``_generated``: the registry tables and API stubs, made from strings of the code, and present in the
    tree only after a build, so a scan would depend on whether one ran first).
    """
    files = {p.relative_to(root) for pattern in SCANNED for p in root.glob(pattern) if p.is_file()}
    return sorted(p for p in files if not {"_build", "auto_examples", "_generated"} & set(p.parts))


def _markdown_prose(text: str) -> list[tuple[int, str]]:
    """(line number, line) of Markdown outside fenced code, indented code and generated blocks."""
    lines = text.splitlines()
    skip: set[int] = set()
    for start, stop in block_spans(text):
        skip.update(range(start, stop + 1))
    fenced = False
    out = []
    for i, line in enumerate(lines):
        if line.lstrip().startswith(("```", "~~~")):
            fenced = not fenced
            continue
        if fenced or i in skip or line.startswith("    ") or line.startswith("\t"):
            continue
        out.append((i + 1, line))
    return out


def _python_prose(text: str) -> list[tuple[int, str]]:
    """(line number, line) of the comments and triple-quoted strings (docstrings) of Python source."""
    out = []
    for tok in tokenize.generate_tokens(io.StringIO(text).readline):
        if tok.type == tokenize.COMMENT:
            out.append((tok.start[0], tok.string))
        elif tok.type == tokenize.STRING and re.match(r"^[rbuRBU]*('''|\"\"\")", tok.string):
            out += [(tok.start[0] + k, line) for k, line in enumerate(tok.string.splitlines())]
    return out


def _code_spans_removed(line: str) -> str:
    """The line without inline code (``x``/`x`), where numbers are values, not claims."""
    return re.sub(r"``[^`]*``|`[^`]*`", "``", line)


def scan(root: str | Path) -> list[Finding]:
    """Every number in the published prose under ``root`` that looks measured and is not allowed."""
    root = Path(root)
    findings = []
    for rel in scanned_files(root):
        text = (root / rel).read_text(encoding="utf-8")
        prose = _python_prose(text) if rel.suffix == ".py" else _markdown_prose(text)
        for number, line in prose:
            if any(str(rel) == f and frag in line for f, frag in ALLOWED):
                continue
            bare = _code_spans_removed(line)
            if DEFINITIONS.search(bare):
                bare = DEFINITIONS.sub("", bare) if ">>>" not in bare and "default" not in bare else ""
            for kind, pattern in PATTERNS.items():
                if pattern.search(bare):
                    findings.append(Finding(str(rel), number, kind, line))
                    break
    return findings


def main(argv: list[str] | None = None) -> int:
    """``python -m tzsl.reporting.typed_numbers [ROOT]``: exit 1 when a typed number is found."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("root", type=Path, nargs="?", default=Path("."))
    args = parser.parse_args(argv)
    findings = scan(args.root)
    for finding in findings:
        print(finding)
    if findings:
        print(f"{len(findings)} typed number(s): generate them (make numbers) or remove them", file=sys.stderr)
        return 1
    print("no typed measured numbers")
    return 0


if __name__ == "__main__":  # pragma: no cover
    raise SystemExit(main())
