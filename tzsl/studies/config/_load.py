"""Reading, checking, overriding and printing experiment files.

:func:`load_experiment` accepts a TOML file or the name of a built-in study (the files in
``tzsl/studies/builtin/``, shipped inside the package). Every problem is reported at once,
one line each, as ``FILE: key.path: reason`` in a :class:`~tzsl.exceptions.ConfigError`.
"""

from __future__ import annotations

import math
import os
import tomllib
from collections.abc import Mapping
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Any, overload

from pydantic import BaseModel, ValidationError

from tzsl._toml import toml_value
from tzsl.exceptions import ConfigError, problems_error
from tzsl.studies.config._registry import get_study, study_names

_BUILTIN_PACKAGE = "tzsl.studies.builtin"


def builtin_names() -> list[str]:
    """Names of the built-in studies (``tzsl run NAME``): the stems of the shipped files, ``_`` -> ``-``."""
    folder = resources.files(_BUILTIN_PACKAGE)
    return sorted(p.name[:-5].replace("_", "-") for p in folder.iterdir() if p.name.endswith(".toml"))


def builtin_text(name: str) -> str:
    """The text of the built-in study ``name``."""
    if name not in builtin_names():
        raise ConfigError(f"{name}: no such experiment file or built-in study (built-in: "
                          f"{', '.join(builtin_names())})")
    return (resources.files(_BUILTIN_PACKAGE) / (name.replace("-", "_") + ".toml")).read_text(encoding="utf-8")


@dataclass
class Experiment:
    """A checked experiment.

    Attributes
    ----------
    source : str
        The file path, ``builtin:NAME`` or ``command line``; starts every error line.
    base : Path
        Relative ``[dataset]`` paths are relative to this folder (the file's folder; the current
        directory for built-in studies and command-line options).
    config : pydantic model
        The resolved settings (every default filled in).
    text : str
        The file's text ("" for a config built from options).
    """

    source: str
    base: Path
    config: Any
    text: str = ""

    @property
    def study(self) -> str:
        return self.config.study

    @overload
    def resolve(self, value: str | os.PathLike) -> Path: ...
    @overload
    def resolve(self, value: None) -> None: ...

    def resolve(self, value: str | os.PathLike | None) -> Path | None:
        """A path of the experiment, relative to :attr:`base`."""
        if value is None:
            return None
        p = Path(os.path.expanduser(os.fspath(value)))
        return p if p.is_absolute() else self.base / p


def _shown(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:57] + "..."


_TYPE_TAGS = {"float", "int", "str", "bool", "list", "dict", "none"}


def _key_path(loc: tuple) -> str:
    """``("splits", "kinds", 1, "literal[...]")`` -> ``splits.kinds[1]`` (union-member tags dropped)."""
    text = ""
    for part in loc:
        if isinstance(part, int):
            text += f"[{part}]"
        elif "[" in part or part in _TYPE_TAGS:
            continue
        else:
            text += f".{part}" if text else part
    return text or "(top level)"


_WORDS = (("input should be greater than or equal to", "must be >="), ("input should be less than or equal to",
          "must be <="), ("input should be greater than", "must be >"), ("input should be less than", "must be <"),
          ("input should be", "expected"))


def _reason(msg: str) -> str:
    msg = msg[:1].lower() + msg[1:]
    for old, new in _WORDS:
        msg = msg.replace(old, new)
    return msg


def _problems(source: str, error: ValidationError) -> list[str]:
    """``source: key.path: reason`` lines of a pydantic error (never its traceback text)."""
    found: dict[str, list[str]] = {}
    for e in error.errors(include_url=False):
        loc = _key_path(e["loc"])
        message = str(e.get("ctx", {}).get("error", "")) or e["msg"]
        if e["type"] == "extra_forbidden":
            message = "unknown key"
        elif e["type"] == "missing":
            message = "missing (required)"
        elif e["type"] in ("model_type", "dict_type"):
            message = f"{_shown(e['input'])}: expected a table"
        elif e["type"] not in ("value_error", "assertion_error"):
            message = f"{_shown(e['input'])}: {_reason(e['msg'])}"
        for part in message.split("\n"):
            key, why = loc, part
            if part.startswith("@"):
                key, _, why = part[1:].partition(": ")
            reasons = found.setdefault(key, [])
            if reasons and why.split(": ")[0] == reasons[-1].split(": ")[0] and ": " in why:
                reasons[-1] += " or " + why.split(": ", 1)[1].removeprefix("expected ")
            else:
                reasons.append(why)
    return [f"{source}: {key}: {why}" for key, reasons in found.items() for why in reasons]


def _no_nan(raw: Any, path: str = "") -> list[str]:
    if isinstance(raw, dict):
        return [p for k, v in raw.items() for p in _no_nan(v, f"{path}.{k}" if path else str(k))]
    if isinstance(raw, list):
        return [p for v in raw for p in _no_nan(v, path)]
    if isinstance(raw, float) and not math.isfinite(raw):
        return [f"{path}: {raw!r}: expected a finite number"]
    return []


def set_value(raw: dict, key: str, value: Any) -> None:
    """Set ``raw[a][b] = value`` for ``key = "a.b"`` (creating tables on the way)."""
    *tables, last = key.split(".")
    node = raw
    for t in tables:
        node = node.setdefault(t, {})
        if not isinstance(node, dict):
            raise ConfigError(f"{key}: {t} is not a table")
    node[last] = value


def validate(raw: dict, source: str, base: Path, text: str = "", overrides: dict[str, Any] | None = None,
             options: Mapping[str, Any] | None = None, strict: bool = True) -> Experiment:
    """Check a parsed experiment (a dict as TOML gives it) and fill in its defaults.

    ``overrides``: ``{"table.key": value}`` set before checking; ``options``: the shared command-line
    options by name (:data:`OPTION_KEYS`, :func:`option_values` with ``strict``), mapped for the study
    this very parse names.
    """
    raw = {k: (dict(v) if isinstance(v, dict) else v) for k, v in raw.items()}
    study = raw.get("study")
    if study is None:
        raise ConfigError(f"{source}: study: missing (one of {', '.join(study_names())})")
    if study not in study_names():
        raise ConfigError(f"{source}: study: {_shown(study)}: expected one of {', '.join(study_names())}")
    given = {**(overrides or {}), **option_values(study, options or {}, strict)}
    for key, value in given.items():
        if value is not None:
            set_value(raw, key, value)
    problems = [f"{source}: {p}" for p in _no_nan(raw)]
    try:
        config = get_study(study).schema.model_validate(raw)
    except ValidationError as exc:
        problems += _problems(source, exc)
    error = problems_error(problems, source)
    if error is not None:
        raise error
    return Experiment(source=source, base=base, config=config, text=text)


def load_experiment(file_or_name: str | os.PathLike, overrides: dict[str, Any] | None = None, *,
                    options: Mapping[str, Any] | None = None, strict: bool = True) -> Experiment:
    """Read and check an experiment file, or a built-in study by name, once.

    ``overrides``: ``{"table.key": value}``; ``options``: the shared command-line options by name
    (``{"n_jobs": 2, "out": "results"}``, :data:`OPTION_KEYS`), mapped for the study the file names
    (``strict``: see :func:`option_values`).

    Raises
    ------
    ConfigError
        Missing file, not UTF-8 text, not TOML, or every schema problem, one per line as
        ``FILE: key.path: reason``.
    """
    path = Path(file_or_name)
    if path.is_file():
        try:
            text = path.read_text(encoding="utf-8")
        except UnicodeDecodeError as exc:
            raise ConfigError(f"{path}: not a text (UTF-8) TOML file: byte {exc.start} cannot be decoded") from None
        except OSError as exc:
            raise ConfigError(f"{path}: cannot read: {exc.strerror}") from None
        source, base = str(path), path.parent
    elif path.suffix == "" and os.sep not in str(file_or_name) and str(file_or_name) in builtin_names():
        text = builtin_text(str(file_or_name))
        source, base = f"builtin:{file_or_name}", Path.cwd()
    elif path.suffix == ".toml" or os.sep in str(file_or_name):
        raise ConfigError(f"{path}: experiment file not found")
    else:
        raise ConfigError(f"{file_or_name}: no such experiment file or built-in study (built-in: "
                          f"{', '.join(builtin_names())})")
    try:
        raw = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ConfigError(f"{source}: not valid TOML: {exc}") from None
    return validate(raw, source, base, text, overrides, options, strict)


def config_from_options(study: str, values: dict[str, Any]) -> Experiment:
    """An experiment built from command-line options (``{"table.key": value}``); paths relative to the
    current directory."""
    return validate({"study": study}, "command line", Path.cwd(), "", values)


def defaults(study: str, **required: Any) -> BaseModel:
    """The schema's defaults of a study (``required``: the tables that have no default, e.g. ``dataset``)."""
    return get_study(study).schema.model_validate({"study": study, **required})


# --------------------------------------------------------------------------- command-line options


#: The command-line option names every front-end shares (``tzsl run``, ``reproduce-tables``, ``evidence``,
#: :func:`tzsl.run`) -> the key of the experiment each sets: the one option-to-schema table.
OPTION_KEYS: dict[str, str] = {
    "out": "output.folder", "n_jobs": "compute.n_jobs", "seed": "splits.seed", "backend": "compute.backend",
    "scheduler": "compute.scheduler", "progress": "compute.progress", "data_dir": "dataset.data_dir",
}
#: Options whose value is a path, made absolute (relative to the current directory, not the file).
_PATH_OPTIONS = ("out", "data_dir")


def _has_key(study: str, key: str) -> bool:
    table, name = key.split(".")
    annotation = get_study(study).schema.model_fields[table].annotation
    return name in getattr(annotation, "model_fields", {})


def option_values(study: str, options: Mapping[str, Any], strict: bool = True) -> dict[str, Any]:
    """``{"n_jobs": 2, ...}`` -> ``{"compute.n_jobs": 2, ...}`` for ``study`` (None = not given).

    ``strict``: an option the study has no key for is an error (``tzsl run``); otherwise it is
    skipped (``reproduce-tables`` applies ``--seed`` to the studies that have one).
    """
    values: dict[str, Any] = {}
    for name, value in options.items():
        if value is None:
            continue
        if name not in OPTION_KEYS:
            raise ConfigError(f"unknown option {name!r} (known: {', '.join(OPTION_KEYS)})")
        key = OPTION_KEYS[name]
        if name in _PATH_OPTIONS:
            value = os.fspath(Path(value).expanduser().absolute())
        if not _has_key(study, key):
            if strict:
                raise ConfigError(f"--{name.replace('_', '-')} does not apply to study {study!r} (no key {key})")
            continue
        values[key] = value
    return values


# --------------------------------------------------------------------------- printing


#: Tables :func:`to_toml` writes before the others, when the study has them.
_LEADING_TABLES = ("dataset", "features")


def to_toml(config: BaseModel) -> str:
    """The resolved experiment as TOML, every key written (unset keys as comments)."""
    data = config.model_dump()
    # the data first, as study files are written (schemas that extend ZeroShotSettings list its tables first)
    data = {k: data[k] for k in sorted(data, key=lambda k: k not in _LEADING_TABLES)}
    lines = []
    for key, value in data.items():
        if not isinstance(value, dict):
            lines.append(f"{key} = {toml_value(value)}")
    for table, values in data.items():
        if not isinstance(values, dict):
            continue
        lines.append(f"\n[{table}]")
        nested = {}
        for key, value in values.items():
            if value is None:
                lines.append(f"# {key} = (unset)")
            elif isinstance(value, dict):
                nested[key] = value
            else:
                lines.append(f"{key} = {toml_value(value)}")
        for key, value in nested.items():
            lines.append(f"\n[{table}.{key}]")
            lines += [f"{k} = {toml_value(v)}" for k, v in value.items() if v is not None]
    return "\n".join(lines) + "\n"
