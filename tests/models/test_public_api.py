"""The public API of tzsl.models (issues 24 and 43): a small top level, rooms by role, one home per helper.

The top level holds what a user builds and catches: the estimators, the decision rules, the
method registry, the exceptions and warnings, and :data:`tzsl.models.INHERITED_CHOICES`. The
estimators live in subpackages by role (``tzsl.models.detectors``, ``.rules``, ``.embedding``,
``.calibration``, ``.ensemble``, ``.hand``, ``.active_touch``), whose ``__init__`` lists them with their
helpers; the top level re-exports the estimators. Every helper function or constant has exactly one
public home (a room or a core module such as ``tzsl.models.dap``) whose ``__all__`` is exact; only the
gateways (:data:`GATEWAYS`: the top level and the method authors' ``tzsl.models.base``), a package
re-exporting its own sub-room, and the two old module names (:data:`ALIASES`) list a name again, and
then it is the same object. The fit store is ``tzsl.fit_store``.
"""

from __future__ import annotations

import importlib
import inspect
import pkgutil

from sklearn.base import BaseEstimator

import tzsl.fit_store
import tzsl.models
from tzsl.models import DecisionRule

#: The registry's names and the one list kept at the top level that are neither classes of
#: estimators nor exceptions.
REGISTRY = {"DAP_METHOD", "FAMILIES", "INPUT_KINDS", "Method", "all_estimators", "available_methods", "build_method",
            "get_method", "method_aliases", "register_alias", "register_method", "unregister_method",
            "INHERITED_CHOICES"}

#: At most this many top-level names. Today: 21 estimators + 4 decision rules + 12 registry names
#: + 6 exceptions/warnings + INHERITED_CHOICES = 44. The bound leaves room for a few new
#: estimators (each adds one name); past it the estimators should be grouped into subpackages,
#: as scikit-learn does, rather than the top level growing without end. Helper functions are kept
#: out by the kind check below, not by this count.
MAX_TOP_LEVEL = 45


#: The rooms by role (issue 43): where the estimators and their helpers live.
ROOMS = {"tzsl.models.detectors", "tzsl.models.rules", "tzsl.models.embedding", "tzsl.models.embedding.deep",
         "tzsl.models.calibration", "tzsl.models.ensemble", "tzsl.models.hand", "tzsl.models.active_touch"}

#: Modules that gather names whose home is elsewhere: the top level and the method authors' module.
GATEWAYS = {"tzsl.models", "tzsl.models.base"}

#: Old public module -> its room: kept so that code written before the rooms imports; every name the same object.
ALIASES = {"tzsl.models.attribute_training": "tzsl.models.detectors", "tzsl.models.multigrasp": "tzsl.models.hand"}

#: Modules that import torch (the optional deep extra): not imported by these tests.
TORCH_MODULES = ("tzsl.models.embedding.deep._backbones", "tzsl.models.embedding.deep._training")


def _all_modules() -> list[str]:
    """Every module under tzsl.models, private ones included, by name (sub-rooms too)."""
    return [info.name for info in pkgutil.walk_packages(tzsl.models.__path__, "tzsl.models.")]


def public_submodules() -> list:
    """Every public module or package under tzsl.models (no ``_`` in its path), imported."""
    return [importlib.import_module(name) for name in _all_modules()
            if not any(part.startswith("_") for part in name.split("."))]


def test_top_level_is_small_and_holds_only_estimators_rules_registry_and_errors():
    names = tzsl.models.__all__
    assert len(names) == len(set(names)), "a name is listed twice in tzsl.models.__all__"
    assert len(names) <= MAX_TOP_LEVEL, f"tzsl.models exports {len(names)} names (at most {MAX_TOP_LEVEL})"
    odd = []
    for name in names:
        obj = getattr(tzsl.models, name)
        kind_ok = inspect.isclass(obj) and (issubclass(obj, (BaseEstimator, DecisionRule, Exception, Warning)))
        if not (kind_ok or name in REGISTRY):
            odd.append(name)
    assert not odd, f"not an estimator, rule, exception or registry name (move to a submodule): {odd}"


def test_every_estimator_and_exception_class_is_at_the_top_level():
    """No estimator (a class with ``fit``), rule or exception of tzsl.models is left out of the top level.

    Shared bases without ``fit`` (the embedding models' predict side) are not estimators by themselves.
    """
    left_out = []
    for name in _all_modules():
        if name in TORCH_MODULES:
            continue  # torch's modules (the optional deep extra); DeepAttributeEmbedding is the estimator
        module = importlib.import_module(name)
        for name, obj in vars(module).items():
            if not (inspect.isclass(obj) and obj.__module__ == module.__name__ and not name.startswith("_")):
                continue
            estimator = issubclass(obj, BaseEstimator) and hasattr(obj, "fit") and not inspect.isabstract(obj)
            if (estimator or issubclass(obj, Exception)) and name not in tzsl.models.__all__:
                left_out.append(f"{module.__name__}.{name}")
    assert not left_out, left_out


def test_every_public_submodule_resolves_its_all_exactly():
    modules = public_submodules() + [tzsl.fit_store]
    assert {m.__name__ for m in modules} >= {
        "tzsl.models.dap", "tzsl.models.multigrasp", "tzsl.models.active_touch", "tzsl.models.calibration",
        "tzsl.models.attribute_training", "tzsl.models.protocol", "tzsl.models.embedding", "tzsl.models.choices",
        "tzsl.models.base", *ROOMS}
    for module in modules:
        names = module.__all__
        assert names and len(names) == len(set(names)), module.__name__
        missing = [n for n in names if not hasattr(module, n)]
        assert not missing, f"{module.__name__}.__all__ names what it does not have: {missing}"
        # exact: every public name bound in the module is listed (imports of modules aside)
        unlisted = [n for n, obj in vars(module).items()
                    if not n.startswith("_") and not inspect.ismodule(obj) and n not in names
                    and n != "annotations"]
        assert not unlisted, f"{module.__name__} binds public names it does not list in __all__: {unlisted}"


def test_every_name_has_exactly_one_public_home():
    listings: dict[str, list[str]] = {}
    for module in [tzsl.models, *public_submodules(), tzsl.fit_store]:
        for name in module.__all__:
            listings.setdefault(name, []).append(module.__name__)
    twice, different = {}, {}
    for name, where in listings.items():
        homes = [m for m in where if m not in GATEWAYS and m not in ALIASES
                 and not any(other.startswith(m + ".") for other in where)]  # a package re-exporting its sub-room
        if len(homes) > 1:
            twice[name] = homes
        objects = {id(getattr(importlib.import_module(m), name)) for m in where}
        if len(objects) > 1:
            different[name] = where
    assert not twice, f"names exported from more than one public home: {twice}"
    assert not different, f"one name, different objects (a gateway must re-export, not redefine): {different}"
    # the fit store is not a model: tzsl.models no longer re-exports it
    assert not set(tzsl.fit_store.__all__) & set(tzsl.models.__all__)


def test_every_top_level_estimator_lives_in_a_room_and_the_old_names_in_theirs():
    rooms = {name: importlib.import_module(name) for name in ROOMS}
    homeless = [name for name in tzsl.models.__all__
                if inspect.isclass(obj := getattr(tzsl.models, name)) and issubclass(obj, BaseEstimator)
                and obj is not tzsl.models.ZeroShotClassifier  # the protocol itself: the package core
                and not any(name in getattr(room, "__all__", ()) for room in rooms.values())]
    assert not homeless, f"top-level estimators no room lists: {homeless}"
    for alias, room in ALIASES.items():
        old, new = importlib.import_module(alias), importlib.import_module(room)
        assert set(old.__all__) <= set(new.__all__), alias
        assert all(getattr(old, n) is getattr(new, n) for n in old.__all__), alias
