"""The study registry: every ``study = NAME`` an experiment file can name, one registration line each.

A study kind is its validated schema (a pydantic model of this package) and the functions that run
it, named as ``"module:function"`` and imported only when a study of that kind runs, so the engine
names no study and imports none:

``runner(exp, results, say) -> StudyRun``
    Runs a checked experiment into a results folder (required).
``results(exp, force) -> ResultsDir``
    Opens the staged results folder and checks that the files it will write are free (default: a
    plain :class:`~tzsl.studies.outputs.results_folder.ResultsDir` checked for ``manifest.json``).
``outputs(config) -> list[str]``
    The files a run writes, checked free by ``tzsl reproduce-tables`` before any study runs.
``notes(exp) -> list[str]``
    What ``tzsl run --check`` says before any fit (the zero-shot study: settings it relaxes).

A new study registers itself with :func:`register_study` (its schema's ``study`` field must
accept the name) and is then found by ``tzsl run``, ``tzsl.run`` and the docs; a paper preset
(``preset_of``) runs another kind's runner: as its whole study (``phac2-dap``) or before its paper protocol
(``fabric``, ``hand``: :mod:`tzsl.studies.zero_shot.preset`).
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from dataclasses import dataclass
from typing import Literal, get_args, overload

from pydantic import BaseModel

from tzsl.exceptions import ConfigError
from tzsl.studies.config._studies import ActiveTouchStudy, FabricDeepStudy, FabricStudy, HandStudy
from tzsl.studies.config._zero_shot import ZeroShotStudy

__all__ = ["StudyKind", "get_study", "register_study", "study_kinds", "study_names", "unregister_study"]


@dataclass(frozen=True)
class StudyKind:
    """One kind of study (``study = name`` in an experiment file).

    Attributes
    ----------
    name : str
        The ``study`` value.
    schema : type[pydantic.BaseModel]
        The experiment file's model: every key, its type and its default.
    runner : str
        ``"module:function"`` running a checked experiment (see the module docstring).
    main_table : str
        The table :func:`tzsl.run` returns by default.
    description : str
        One line for ``tzsl run --help`` and the docs.
    results, outputs, notes : str or None
        Optional ``"module:function"`` hooks (see the module docstring).
    preset_of : str or None
        The generic kind this one presets (the paper's dataset, protocol and numbers).
    requires : tuple of str
        Optional libraries the study imports (checked before any fit).
    extra : str or None
        The ``pip install 'tzsl[extra]'`` that brings them.
    """

    name: str
    schema: type[BaseModel]
    runner: str
    main_table: str
    description: str
    results: str | None = None
    outputs: str | None = None
    notes: str | None = None
    preset_of: str | None = None
    requires: tuple[str, ...] = ()
    extra: str | None = None

    @overload
    def hook(self, which: Literal["runner"]) -> Callable: ...
    @overload
    def hook(self, which: str) -> Callable | None: ...

    def hook(self, which: str) -> Callable | None:
        """The imported ``runner`` / ``results`` / ``outputs`` / ``notes`` function (None when not set)."""
        target = getattr(self, which)
        if target is None:
            return None
        module, _, function = target.partition(":")
        return getattr(importlib.import_module(module), function)


_STUDIES: dict[str, StudyKind] = {}


def register_study(name: str, **fields) -> StudyKind:
    """Register the study kind ``name`` (fields: those of :class:`StudyKind`); returns it.

    Raises
    ------
    ValueError
        When ``name`` is taken or the schema's ``study`` field does not accept ``name``.
    """
    if name in _STUDIES:
        raise ValueError(f"study {name!r} is already registered")
    kind = StudyKind(name=name, **fields)
    accepted = get_args(kind.schema.model_fields["study"].annotation)  # the schema's Literal["name", ...]
    if name not in accepted:
        raise ValueError(f"study {name!r}: the schema {kind.schema.__name__}.study does not accept it ({accepted})")
    _STUDIES[name] = kind
    return kind


def unregister_study(name: str) -> None:
    """Remove a registered study kind (a plug-in's tests; the built-in kinds stay registered)."""
    _STUDIES.pop(name, None)


def get_study(name: str, source: str = "study") -> StudyKind:
    """The registered study kind ``name``; a ConfigError naming ``source`` and the known kinds otherwise."""
    if name not in _STUDIES:
        raise ConfigError(f"{source}: {name!r}: expected one of {', '.join(_STUDIES)}")
    return _STUDIES[name]


def study_kinds() -> list[StudyKind]:
    """Every registered study kind, in registration order."""
    return list(_STUDIES.values())


def study_names() -> tuple[str, ...]:
    """The names of every registered study kind."""
    return tuple(_STUDIES)


_ZERO_SHOT = "tzsl.studies.zero_shot.runner"
_ZERO_SHOT_HOOKS = {"runner": f"{_ZERO_SHOT}:run_zero_shot", "results": f"{_ZERO_SHOT}:zero_shot_results",
                    "outputs": f"{_ZERO_SHOT}:zero_shot_outputs", "notes": f"{_ZERO_SHOT}:relaxation_notes",
                    "main_table": "table1_fusion"}

register_study("zero-shot", schema=ZeroShotStudy, **_ZERO_SHOT_HOOKS,
               description="any dataset x DAP and every registered method x random and challenging unseen-object "
                           "splits, GZSL, attribute tables")
register_study("phac2-dap", schema=ZeroShotStudy, **_ZERO_SHOT_HOOKS, preset_of="zero-shot",
               description="the DAP paper's PHAC-2 protocol (Tables 1-3), with the paper's numbers beside ours")
_FABRIC, _HAND = "tzsl.studies.fabric.runner", "tzsl.studies.hand.runner"
register_study("fabric", schema=FabricStudy, runner=f"{_FABRIC}:run_fabric", results=f"{_FABRIC}:fabric_results",
               outputs=f"{_FABRIC}:fabric_outputs", notes=f"{_FABRIC}:fabric_notes", main_table="table1",
               preset_of="zero-shot",
               description="the generic study on fabric-depth, then the fabric paper: embedding models on fabric "
                           "groups (Table 1 analogue), group partitions")
register_study("fabric-deep", schema=FabricDeepStudy, runner="tzsl.studies.fabric.runner:run_fabric_deep",
               main_table="table", requires=("torch",), extra="deep",
               description="the fabric paper's CNN + LSTM over key frames, over the lambda grid (needs torch)")
register_study("hand", schema=HandStudy, runner=f"{_HAND}:run_hand", results=f"{_HAND}:hand_results",
               outputs=f"{_HAND}:hand_outputs", notes=f"{_HAND}:hand_notes", main_table="table5", preset_of="zero-shot",
               description="the generic study on hand-simulated, then the DAP paper's Shadow-hand study (Tables 4-5, "
                           "multi-grasp), on SIMULATED grasps unless given real ones")
register_study("active-touch", schema=ActiveTouchStudy, runner="tzsl.studies.active_touch.runner:run_active_touch",
               outputs="tzsl.studies.active_touch.runner:active_touch_outputs", main_table="active_touch",
               description="choosing the next exploratory procedure and when to stop, on PHAC-2 EPs")
