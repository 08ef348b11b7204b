"""What the report reads from a results folder's manifests: the studies run, paper or not, relaxations, deviations.

A manifest's ``config`` is one study's record (``tzsl run``: ``study``, ``labels``, ``dataset``,
``relaxations``, ...) or several under ``studies`` (``tzsl reproduce-tables``, ``tzsl evidence``).
:func:`study_records` reads either. A record is of a *paper* study unless its kind is the generic
one that the papers' presets preset (the study registry's ``preset_of``: ``zero-shot``) or its
labels say ``paper = false``; the report of a folder with any paper study is laid out by the
papers' tables and says where the runs deviate from the papers (:func:`deviations`), the report
of a generic study by what its sections show.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

__all__ = [
    "config_items", "dataset_names", "deviations", "dict_at", "environment_phrase", "is_paper_record",
    "produced_by", "read_manifest", "relaxations", "study_records"
]

#: The manifest key of the zero-shot study's settings by table (``"dap_settings"`` in manifests written
#: before it was renamed: still read, so older results folders report the same).
ZERO_SHOT_SETTINGS_KEYS = ("study_settings", "dap_settings")


def read_manifest(path: Path) -> tuple[dict, str]:
    """The manifest at ``path`` as a dict (empty when not a JSON object) and as indented text."""
    text = path.read_text(encoding="utf-8", errors="replace")
    try:
        data = json.loads(text)
        return (data if isinstance(data, dict) else {}), json.dumps(data, indent=2, sort_keys=True)
    except json.JSONDecodeError:
        return {}, text


def dict_at(record: dict, key: str) -> dict:
    """``record[key]`` when it is a dict (a JSON object), else an empty dict."""
    value = record.get(key)
    return value if isinstance(value, dict) else {}


def environment_phrase(manifest: dict) -> str:
    """How a manifest's environment stands to the lock, for a generated block's first line.

    ``"in the locked environment (`requirements/core.lock.txt`, sha256 `fb3f0682`)"``; or which locked
    packages differed; or that the run recorded no environment (a manifest older than the lock) or
    had no lock (an installed wheel).
    """
    env = manifest.get("environment")
    if not isinstance(env, dict):
        return "environment not recorded"
    lock, sha = env.get("lock_file"), str(env.get("lock_sha256") or "")[:8]
    if not lock:
        return "outside a checkout with a lock (versions in its manifest)"
    if env.get("matches_lock"):
        return f"in the locked environment (`{lock}`, sha256 `{sha}`)"
    differs = dict_at(env, "differs")
    listed = ", ".join(f"{name} {(v or {}).get('installed') or 'missing'} (locked {(v or {}).get('locked')})"
                       for name, v in sorted(differs.items()))
    return f"NOT in the locked environment (`{lock}`, sha256 `{sha}`): {listed}"


def study_records(manifest: dict) -> dict[str, dict]:
    """Study name -> its record: the ``studies`` of a multi-study manifest, or the one study of a run
    (empty when the manifest names no study)."""
    config = dict_at(manifest, "config")
    studies = config.get("studies")
    if isinstance(studies, dict):
        return {str(k): v for k, v in studies.items() if isinstance(v, dict)}
    return {str(config["study"]): config} if isinstance(config.get("study"), str) else {}


def is_paper_record(record: dict) -> bool:
    """Whether a study record is of a paper study (see the module docstring)."""
    from tzsl.studies.config import study_kinds  # noqa: PLC0415 (the registry imports the schemas)

    labels = dict_at(record, "labels")
    if labels.get("paper") is False:
        return False
    generic = {kind.preset_of for kind in study_kinds()} - {None}
    return labels.get("paper") is True or record.get("study") not in generic


def dataset_names(records: dict[str, dict]) -> list[str]:
    """The datasets the records ran on (``dataset`` or ``labels.data``), in order, once each."""
    names = []
    for record in records.values():
        labels = dict_at(record, "labels")
        name = record.get("dataset") or labels.get("data")
        if isinstance(name, str) and name:
            names.append(name)
    return list(dict.fromkeys(names))


def relaxations(records: dict[str, dict]) -> list[str]:
    """One sentence per setting a run relaxed to fit its dataset (the records' ``relaxations``, also
    those of a preset's generic part under ``zero_shot``)."""
    out = []
    for record in records.values():
        nested = dict_at(record, "zero_shot")
        for item in [*(record.get("relaxations") or []), *(nested.get("relaxations") or [])]:
            if not isinstance(item, dict):
                continue
            changed = f": asked {item['asked']}, used {item['used']}" if "asked" in item and "used" in item else ""
            out.append(f"{item.get('setting', '?')}{changed} ({item.get('why', 'no reason recorded')})")
    return list(dict.fromkeys(out))


def config_items(config: dict) -> dict[str, Any]:
    """A manifest's configuration (or one study's record) flattened one level (study configs nested by
    name merged in)."""
    flat: dict[str, Any] = {}
    for key, value in config.items():
        by_table = key in ZERO_SHOT_SETTINGS_KEYS  # the zero-shot study's settings, by table
        if isinstance(value, dict) and (by_table or key in ("fabric", "hand")):
            flat.update({k: v for t in value.values() for k, v in t.items()} if by_table else value)
        else:
            flat[key] = value
    return flat


def _record_deviations(c: dict[str, Any], where: str) -> list[str]:
    """The deviation sentences of one flattened study configuration ``c``, each ending with ``where``."""
    out: list[str] = []
    svm = c.get("svm_params")
    if isinstance(svm, dict):
        cv = svm.get("cv", "absent")
        if cv is not None and cv != "absent":
            out.append(f"Attribute SVMs tuned by {cv}-fold object-grouped cross-validation; the paper uses "
                       f"leave-one-object-out {where}.")
        grid = svm.get("grid")
        if grid not in (None, "paper"):
            out.append(f"SVM hyper-parameter grid {grid!r} instead of the paper's {where}.")
        reduced = {k: svm[k] for k in ("n_C", "n_gamma", "n_draws") if k in svm}
        if reduced:
            out.append(f"Reduced SVM search {reduced} {where}.")
    if "random_min_train_positives" in c:
        out.append(f"Random splits leave out attributes with fewer than {c['random_min_train_positives']} "
                   f"positive training objects (the paper states no rule for random splits) {where}.")
    if c.get("challenging_min_train_positives") not in (None, 3):
        out.append(f"Challenging splits require {c['challenging_min_train_positives']} positive training "
                   f"objects per attribute (paper: 3) {where}.")
    if c.get("undersampling") not in (None, "select"):
        out.append(f"Class-0 under-sampling {c['undersampling']!r} (paper: one random draw) {where}.")
    for key, paper in (("n_splits", 5), ("n_test", 10), ("sweep_max_subsets", 1000)):
        if key in c and c[key] != paper:
            out.append(f"{key} = {c[key]} (paper: {paper}) {where}.")
    if c.get("hand_data") == "simulated" or c.get("simulated") is True:
        out.append(f"Hand study on SIMULATED grasps: the paper's Shadow-hand recordings are not public, "
                   f"so its numbers are not comparable to Table 5 {where}.")
    if c.get("duplicate_groups"):
        out.append(f"Fabric attribute rows shared by groups {c['duplicate_groups']}: a test group sharing "
                   f"its row with a training group is not zero-shot {where}.")
    if c.get("dataset"):
        out.append(f"Dataset and features: {c['dataset']} {where}.")
    if isinstance(c.get("n_features"), dict):
        units = dict_at(c, "units")
        described = "; ".join(f"{k}: {v} features per {units.get(k, 'sample')}" for k, v in c["n_features"].items())
        out.append(f"Features used: {described} {where}.")
    if c.get("lams") is not None and c.get("alphas") is not None:
        lams, alphas = (", ".join(map(str, c[k])) for k in ("lams", "alphas"))
        out.append(f"Embedding model: lambda in {{{lams}}}, alpha chosen from {{{alphas}}} by class-grouped "
                   f"cross-validation on the training groups {where}.")
    return out


def deviations(manifests: dict[str, dict]) -> list[str]:
    """Sentences saying where the recorded runs differ from the papers' protocols.

    Read from the manifests' configurations, study by study in a multi-study manifest (the
    zero-shot study's ``study_settings`` tables, the fabric and hand study configs); a key absent
    from every manifest yields no sentence.
    """
    out: list[str] = []
    for name, manifest in manifests.items():
        config = dict_at(manifest, "config")
        studies = study_records(manifest)
        for study, record in (studies if "studies" in config else {"": config}).items():
            out += _record_deviations(config_items(record), f"({name}: {study})" if study else f"({name})")
        where = f"({name})"
        for key in ("grid_edges", "grid_edge_warnings"):
            if manifest.get(key):
                out.append(f"Selected hyper-parameters on a grid edge: {manifest[key]} {where}.")
    return list(dict.fromkeys(out))


def produced_by(root: Path) -> str:
    """Which command and commit wrote the results folder ``root``, from its ``manifest.json``.

    ``"`tzsl reproduce-tables` at commit `0123abcd4567`, in the locked environment (...)"``; says what
    is not recorded (no manifest, a manifest of a single study, a run outside a git checkout).
    """
    path = root / "manifest.json"
    try:
        manifest = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return "no manifest.json: command and commit not recorded"
    command = manifest.get("study_list")
    commit = manifest.get("commit")
    text = f"`tzsl {command}`" if command else "a command not recorded"
    text += f" at commit `{commit}`" if commit else ", commit not recorded"
    return f"{text}, {environment_phrase(manifest)}"
