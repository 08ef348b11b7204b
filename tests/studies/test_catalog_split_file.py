"""``[splits] kinds = ["file"]`` without ``file``: a built-in dataset that ships no split file is one line.

A catalog dataset that ships its publication's split runs it: tests/datasets/test_physiclear.py.
"""

from __future__ import annotations

from tests.datasets.fetch_server import run_cli

STUDY = 'study = "zero-shot"\n[dataset]\nbuiltin = "{builtin}"\ndata_dir = "{home}"\n[output]\nfolder = "{out}"\n'


def test_a_builtin_without_a_split_file_is_one_line(tmp_path):
    text = STUDY.format(builtin="hand-simulated", home=tmp_path, out=tmp_path / "r") + '[splits]\nkinds = ["file"]\n'
    (tmp_path / "hand.toml").write_text(text)
    code, out, err = run_cli("run", str(tmp_path / "hand.toml"), "--no-progress")
    assert code == 3 and "splits.kinds: ['file'] needs file = a split CSV" in err, err  # before any data is read
    assert len(err.strip().splitlines()) == 1
