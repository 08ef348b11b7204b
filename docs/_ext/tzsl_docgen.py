"""Pages of the documentation that are generated from the code at build time.

Nothing here is typed by hand: the API reference lists every public name (``__all__`` of every
public package and module of tzsl), the command reference is ``tzsl COMMAND --help``, the method
list is ``tzsl methods --json``, the inherited choices are ``tzsl.models.choices.inherited_choices()``, the
plain format is ``tzsl formats`` and the experiment-file reference is ``tzsl run NAME --print-config``.
Everything is written under ``docs/_generated/``
(not tracked by git) before Sphinx reads the sources, so the pages follow the code.
"""

from __future__ import annotations

import contextlib
import importlib
import inspect
import io
import json
import pkgutil
import shutil
from pathlib import Path

#: Packages shown first in the API reference, in this order (the data flow); the others follow
#: alphabetically.
FIRST = ("tzsl", "tzsl.datasets", "tzsl.features", "tzsl.models", "tzsl.evaluation", "tzsl.studies",
         "tzsl.reporting", "tzsl.inference", "tzsl.benchmarks", "tzsl.cli")
#: Modules that gather names whose home is another module (the method authors' module, the old names of two
#: rooms of tzsl.models): listed after every other module, so a name is documented in its home and linked from these.
GATHERING = ("tzsl.models.base", "tzsl.models.attribute_training", "tzsl.models.multigrasp")
#: Constants whose ``repr`` is longer than this are shown without their value.
LONG_VALUE = 300


class DocGenError(RuntimeError):
    """A page could not be generated (the build stops: no silent gaps in the docs)."""


# --------------------------------------------------------------------------- helpers


def _write(path: Path, text: str) -> None:
    """Write ``text`` to ``path`` only when it changed (keeps incremental builds incremental)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    if not path.exists() or path.read_text(encoding="utf-8") != text:
        path.write_text(text, encoding="utf-8")


def _heading(text: str, char: str = "=") -> str:
    return f"{text}\n{char * len(text)}\n"


def tzsl_cli(*argv: str) -> str:
    """Standard output of ``tzsl ARGV`` run in-process; raises DocGenError on a non-zero exit."""
    from tzsl.cli import main

    out, err = io.StringIO(), io.StringIO()
    code = 0
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            main(list(argv))
        except SystemExit as exc:
            code = exc.code or 0
    if code != 0:
        raise DocGenError(f"`tzsl {' '.join(argv)}` exited with {code}: {err.getvalue().strip()}")
    return out.getvalue()


# --------------------------------------------------------------------------- API reference


def public_units() -> list[str]:
    """Every public package and module of tzsl (no path component starting with ``_``)."""
    import tzsl

    names = ["tzsl"]
    for info in pkgutil.walk_packages(tzsl.__path__, "tzsl."):
        if not any(part.startswith("_") for part in info.name.split(".")):
            names.append(info.name)
    rank = {name: i for i, name in enumerate(FIRST)}
    return sorted(names, key=lambda n: (n in GATHERING, rank.get(n, len(FIRST)), n.count("."), n))


def public_names(module) -> list[str]:
    """``__all__``, or else the classes and functions defined in the module without a leading ``_``."""
    names = getattr(module, "__all__", None)
    if names is None:
        names = [
            n for n, obj in vars(module).items()
            if not n.startswith("_") and (inspect.isclass(obj) or inspect.isfunction(obj))
            and getattr(obj, "__module__", None) == module.__name__
        ]
    return sorted(names, key=str.lower)


def _identity(obj):
    """A key naming the object itself (constants such as strings are not deduplicated)."""
    return id(obj) if (inspect.isclass(obj) or inspect.isroutine(obj)) else None


def api_pages(out: Path) -> list[str]:
    """Write one page per public package / module; return the page names, in order."""
    canonical: dict[int, str] = {}
    pages = []
    for unit in public_units():
        module = importlib.import_module(unit)
        names = public_names(module)
        documented, constants, aliases = [], [], []
        for name in names:
            try:
                obj = getattr(module, name)
            except AttributeError as exc:
                raise DocGenError(f"{unit}.__all__ names {name!r}, which the module does not have") from exc
            key = _identity(obj)
            if key is None:  # a constant: shown with its value on the module's page
                constants.append((name, obj))
                continue
            if key in canonical:
                aliases.append((name, canonical[key]))
                continue
            canonical[key] = f"{unit}.{name}"
            documented.append(name)
        if not (documented or constants or aliases or (module.__doc__ or "").strip()):
            continue
        lines = [_heading(f"``{unit}``"), f".. automodule:: {unit}", "   :no-members:", "",
                 f".. currentmodule:: {unit}", ""]
        if documented:
            lines += [".. autosummary::", "   :toctree: generated/", "   :nosignatures:", ""]
            lines += [f"   {name}" for name in documented]
            lines.append("")
        if constants:
            lines += [_heading("Constants", "-")]
            for name, obj in constants:
                lines.append(f".. autodata:: {name}")
                if len(repr(obj)) > LONG_VALUE:
                    lines.append("   :no-value:")
                lines.append("")
        if aliases:
            lines += ["Also exported here (documented where first listed):", ""]
            lines += [f"* ``{unit}.{name}``: :obj:`{target}`" for name, target in aliases]
            lines.append("")
        _write(out / f"{unit}.rst", "\n".join(lines))
        pages.append(unit)
    return pages


# --------------------------------------------------------------------------- command line


def cli_page(out: Path) -> None:
    """``tzsl --help`` and ``tzsl COMMAND --help`` of every command, as one page."""
    from tzsl.cli import cli

    lines = ["```text", tzsl_cli("--help").rstrip(), "```", ""]
    for name in sorted(cli.commands):
        lines += [f"## `tzsl {name}`", "", "```text", tzsl_cli(name, "--help").rstrip(), "```", ""]
    _write(out / "cli_commands.md", "\n".join(lines))


# --------------------------------------------------------------------------- methods


def methods_page(out: Path) -> None:
    """The method registry: a table (name, family, what it is, paper) and each method's parameters."""
    methods = json.loads(tzsl_cli("methods", "--json"))
    if not methods:
        raise DocGenError("`tzsl methods --json` lists no method")
    lines = ["| method | family | what it is | paper |", "|---|---|---|---|"]
    for m in methods:
        cells = [f"`{m['name']}`", m["family"], m["description"], m.get("paper") or "-"]
        lines.append("| " + " | ".join(str(c).replace("|", "\\|") for c in cells) + " |")
    lines.append("")
    for m in methods:
        lines += [f"### `{m['name']}`", "", m["description"], ""]
        lines.append("Built from " + ", ".join(f"`{c}`" for c in m["components"]) + ".")
        if m.get("preset"):
            lines.append("Fixed for this method: " + ", ".join(f"`{k} = {v!r}`" for k, v in m["preset"].items()) + ".")
        lines.append("")
        if m.get("parameters"):
            values = m.get("values", {})
            lines += ["| parameter | default | values |", "|---|---|---|"]
            lines += [f"| `{k}` | `{v!r}` | {', '.join(f'`{x}`' for x in values.get(k, [])) or '-'} |"
                      for k, v in m["parameters"].items()]
            lines.append("")
        if m.get("aliases"):
            lines += ["Older names, still accepted wherever a method is named (experiment files, `--method`, "
                      "`build_method`), each one configuration of this method:", ""]
            for alias, fixed in m["aliases"].items():
                call = ", ".join(f"{k}={v!r}" for k, v in fixed.items())
                lines.append(f"* `{alias}` = `{m['name']}({call})`")
            lines.append("")
    _write(out / "methods_table.md", "\n".join(lines))


def datasets_page(out: Path) -> None:
    """The dataset registry (``tzsl datasets --json``): name, what it holds, its content, where it comes from."""
    datasets = json.loads(tzsl_cli("datasets", "--json"))
    if not datasets:
        raise DocGenError("`tzsl datasets --json` lists no dataset")
    lines = ["| name (`--dataset`, `[dataset] builtin`) | what it is | content | source |", "|---|---|---|---|"]
    for d in datasets:
        what = d["description"] + ("; needs `path`" if d["needs_path"] else "")
        cells = [f"`{d['name']}`", what, f"{d['content']} ({', '.join(d['eps'])})", d["source"]]
        lines.append("| " + " | ".join(str(c).replace("|", "\\|") for c in cells) + " |")
    _write(out / "datasets_table.md", "\n".join(lines) + "\n")
def choices_page(out: Path) -> None:
    """Every choice a user inherits (:data:`tzsl.models.INHERITED_CHOICES`), values read from the code."""
    from tzsl.models.choices import inherited_choices

    choices = inherited_choices()
    if not choices:
        raise DocGenError("tzsl.models.INHERITED_CHOICES lists no choice")
    lines = []
    for c in choices:
        lines += [f"### `{c['key']}`", "", c["what"][:1].upper() + c["what"][1:] + ".", "",
                  f"* **value:** `{c['value']}`", f"* **datasets it saw:** {c['datasets']}",
                  f"* **chosen on:** {c['selection']}",
                  f"* **numbers shown for it:** {c['numbers']}",
                  f"* **makes the choice again:** {'`' + c['command'] + '`' if c['command'] else 'no command'}", ""]
    _write(out / "choices_table.md", "\n".join(lines))


# --------------------------------------------------------------------------- formats, experiment files


def formats_page(out: Path) -> None:
    """``tzsl formats``: the plain-file dataset format as the program prints it."""
    _write(out / "plain_format.md", "```text\n" + tzsl_cli("formats").rstrip() + "\n```\n")


def experiments_page(out: Path, repo: Path) -> None:
    """Every built-in study, resolved with every default (``tzsl run NAME --print-config``)."""
    from tzsl.studies.config import builtin_names

    lines = []
    for name in builtin_names():
        lines += [f"### `{name}`", "", "```toml", tzsl_cli("run", name, "--print-config").rstrip(), "```", ""]
    _write(out / "builtin_studies.md", "\n".join(lines))
    template = repo / "experiments" / "my_dataset_template.toml"
    _write(out / "template.md", "```toml\n" + template.read_text(encoding="utf-8").rstrip() + "\n```\n")


def generate(docs: Path) -> None:
    """Write every generated page under ``docs/_generated`` (wiped first: no stale pages)."""
    out = docs / "_generated"
    api = out / "api"
    keep = {p.name for p in api.glob("*.rst")} if api.is_dir() else set()
    pages = api_pages(api)
    for stale in keep - {f"{p}.rst" for p in pages}:
        (api / stale).unlink()
    toc = ["```{toctree}", ":maxdepth: 1", ""] + [f"/_generated/api/{p}" for p in pages] + ["```", ""]
    _write(out / "api_toc.md", "\n".join(toc))
    stubs = api / "generated"  # autosummary's stubs: regenerated from the pages above
    if stubs.is_dir():
        shutil.rmtree(stubs)
    cli_page(out)
    methods_page(out)
    datasets_page(out)
    choices_page(out)
    formats_page(out)
    experiments_page(out, docs.parent)
