"""The method registry: every zero-shot method by name, and ``all_estimators()``.

A method is an attribute model class plus a decision rule class (built into a
:class:`tzsl.models.ZeroShotClassifier`), or one self-contained estimator class (the hand's
:class:`~tzsl.models.HandDAPClassifier`, the CNN+LSTM). Adding a method is one class plus one
line::

    register_method("my-method", family="embedding", paper="Me et al. 2024",
                    attribute_model=MyAttributeModel, decision_rule=NearestAttributeRule)

or, as a decorator on the attribute model class::

    @register_method("my-method", family="embedding", paper="...", decision_rule=NearestAttributeRule)
    class MyAttributeModel(BaseEstimator): ...

Parameters and their defaults are read from the classes' ``__init__`` signatures (never
written twice); ``preset`` fixes some of them for the method (``ldap`` is ``HandDAPClassifier``
with ``fusion="ldap"``) and ``defaults`` changes a default the method keeps settable (``dap``'s
uniform prior). The string values a parameter accepts are read from its class's
``_parameter_constraints`` (:meth:`Method.options`) and checked when the method is built. A study
builds a method with :func:`build_method`.

An *alias* is an older name of one configuration of a method, which experiment files, ``--method``
and :func:`get_method` still accept: ``register_alias("dap-max", "dap", preset={"fusion": "max",
"prior": "uni"})``. :func:`available_methods` lists methods, :func:`method_aliases` the aliases,
each as the method entry it names.

A *calibratable* method (every attribute model + decision rule method, and estimators registered
with ``calibratable=True``) is built inside a
:class:`~tzsl.models.CalibratedZeroShotClassifier`, so its ``predict_proba`` is calibrated on
pseudo-unseen training classes; its parameters ``calibration`` and ``calibration_folds`` (defaults
from that class's signature) turn it off (``calibration="none"``: the bare method is built) or
change the folds.
"""

from __future__ import annotations

import inspect
from collections.abc import Mapping
from dataclasses import dataclass, field, replace
from types import MappingProxyType

from sklearn.base import BaseEstimator
from sklearn.utils._param_validation import StrOptions

from tzsl.exceptions import ConfigError
from tzsl.models.calibration import CalibratedZeroShotClassifier

__all__ = [
    "DAP_METHOD",
    "FAMILIES",
    "INPUT_KINDS",
    "Method",
    "all_estimators",
    "available_methods",
    "build_method",
    "get_method",
    "method_aliases",
    "register_alias",
    "register_method",
    "unregister_method",
]

#: Method families shown by ``tzsl methods``.
FAMILIES = ("attribute-classifier", "embedding", "compatibility", "ensemble")
#: What a method fits on: feature vectors (per trial, optionally per sensor), hand grasps (packed
#: per-finger features + contacts + joint angles, :func:`tzsl.features.grasp_features`), or
#: frame sequences (n, T, H, W[, C]). A study runs the methods of its input kind.
INPUT_KINDS = ("features", "grasps", "frames")

DAP_PAPER = (
    "Abderrahmane, Ganesh, Crosnier, Cherubini (2018): Haptic zero-shot learning: recognition of "
    "objects never touched before. Robotics and Autonomous Systems 105"
)
FABRIC_PAPER = "Fabric recognition using zero-shot learning (Tsinghua Sci. Technol. 2019), F15 loss C + lambda R"
ESZSL_PAPER = "Romera-Paredes, Torr (2015): An embarrassingly simple approach to zero-shot learning. ICML"
#: The registered name of DAP: its ``detector``, ``fusion`` and ``prior`` are parameters, and the older
#: names of some of its configurations (``dap-avg``, ``dap-max``, ``dap-avg-logistic-c1``, ...) are aliases.
DAP_METHOD = "dap"

_REGISTRY: dict[str, Method] = {}
#: Alias -> (the method it names, the parameters it fixes).
_ALIASES: dict[str, tuple[str, Mapping[str, object]]] = {}


def _init_defaults(cls: type[object]) -> dict[str, object]:
    """Keyword parameters of ``cls.__init__`` with their defaults, in signature order."""
    sig = inspect.signature(cls.__init__)
    return {
        name: p.default
        for name, p in sig.parameters.items()
        if name != "self" and p.kind in (p.KEYWORD_ONLY, p.POSITIONAL_OR_KEYWORD)
    }


@dataclass(frozen=True)
class Method:
    """One registered zero-shot method.

    Attributes
    ----------
    name : str
        Registry name (``"dap"``, ``"eszsl"``, ...), or the alias it was looked up by.
    family : str
        One of :data:`FAMILIES`.
    paper : str
        Where the method comes from.
    attribute_model, decision_rule : type or None
        Classes composed into a :class:`~tzsl.models.ZeroShotClassifier`.
    estimator : type or None
        A self-contained estimator class instead (hand, deep).
    preset : mapping
        Parameters fixed for this method.
    defaults : mapping
        Settable parameters whose default the method changes from its class's (``dap``: ``prior="uni"``).
    description : str
        One line for ``tzsl methods``.
    input_ndim : {2, 3}
        Trial input the method fits on: 2 = ``(n_trials, n_features)`` (sensors side by side),
        3 = ``(n_trials, n_sensors, n_features)`` (one model per sensor, fused by the rule).
    input_kind : {"features", "grasps", "frames"}
        See :data:`INPUT_KINDS`.
    calibratable : bool
        Built inside a :class:`~tzsl.models.CalibratedZeroShotClassifier` (parameters
        ``calibration``, ``calibration_folds``).
    alias_of : str or None
        The method an alias names (its ``preset`` holds the parameters the alias fixes); None for a method.
    """

    name: str
    family: str
    paper: str
    attribute_model: type | None = None
    decision_rule: type | None = None
    estimator: type | None = None
    preset: Mapping[str, object] = field(default_factory=dict)
    description: str = ""
    input_ndim: int = 2
    input_kind: str = "features"
    calibratable: bool = False
    defaults: Mapping[str, object] = field(default_factory=dict)
    alias_of: str | None = None

    def components(self) -> list[type]:
        """Classes whose parameters the method exposes (estimator, or model then rule)."""
        if self.estimator is not None:
            return [self.estimator]
        assert self.attribute_model is not None and self.decision_rule is not None  # register_method checks it
        return [self.attribute_model, self.decision_rule]

    def parameters(self) -> dict[str, object]:
        """Settable parameters and their defaults (presets excluded), read from the signatures."""
        out: dict[str, object] = {}
        for cls in self.components():
            for name, default in _init_defaults(cls).items():
                if name not in self.preset:
                    out.setdefault(name, self.defaults.get(name, default))
        if self.estimator is None:
            out.setdefault("random_state", None)  # the classifier's tie-breaking seed
        if self.calibratable:
            out.update(_calibration_parameters())
        return out

    def options(self) -> dict[str, tuple[str, ...]]:
        """The string values each settable parameter accepts, sorted (``{"detector": ("auto", ...), ...}``).

        Read from the ``StrOptions`` of the classes' ``_parameter_constraints`` (a parameter that also
        accepts any string is left out); never listed a second time.
        """
        settable = self.parameters()
        out: dict[str, tuple[str, ...]] = {}
        for name, constraints in _constraints(self).items():
            if name not in settable or str in constraints:
                continue
            values = {v for c in constraints if isinstance(c, StrOptions) for v in c.options - c.deprecated}
            if values:
                out[name] = tuple(sorted(values))
        return out

    def value_problems(self, params: Mapping[str, object]) -> dict[str, str]:
        """Each string parameter value of ``params`` that is not among :meth:`options`, with one line saying so."""
        options = self.options()
        return {key: f"method {self.name!r}: {key} = {value!r} is not one of {', '.join(options[key])}"
                for key, value in params.items()
                if key in options and isinstance(value, str) and value not in options[key]}

    def build(self, **params) -> BaseEstimator:
        """An unfitted estimator of this method.

        Parameters
        ----------
        **params
            Any of :meth:`parameters`. ``random_state`` seeds the attribute model (when it has
            one) and the tie-breaking of the :class:`~tzsl.models.ZeroShotClassifier`.

        Returns
        -------
        estimator
            A :class:`~tzsl.models.ZeroShotClassifier`, or the method's own estimator.

        Raises
        ------
        ConfigError
            An unknown parameter, one fixed by the method's preset, or a string value the
            parameter does not accept (:meth:`options`).
        """
        fixed = sorted(set(params) & set(self.preset))
        if fixed:
            raise ConfigError(f"method {self.name!r}: parameter(s) {fixed} are fixed ({dict(self.preset)})")
        unknown = sorted(set(params) - set(self.parameters()))
        if unknown:
            raise ConfigError(
                f"method {self.name!r}: unknown parameter(s) {unknown}; known: {sorted(self.parameters())}"
            )
        problems = self.value_problems(params)
        if problems:
            raise ConfigError(next(iter(problems.values())))
        merged = {**{k: v for k, v in self.defaults.items() if k not in self.preset}, **self.preset, **params}
        calibrator = _calibrator()
        calibration = {k: merged.pop(k) for k in list(merged)
                       if self.calibratable and k in _calibration_parameters()}
        if self.estimator is not None:
            bare = self.estimator(**merged)
        else:
            from tzsl.models._zero_shot import ZeroShotClassifier  # noqa: PLC0415 (import cycle)

            model_cls, rule_cls = self.components()
            model_keys, rule_keys = _init_defaults(model_cls), _init_defaults(rule_cls)
            model = model_cls(**{k: v for k, v in merged.items() if k in model_keys})
            rule = rule_cls(**{k: v for k, v in merged.items() if k in rule_keys and k not in model_keys})
            bare = ZeroShotClassifier(attribute_model=model, decision_rule=rule,
                                      random_state=merged.get("random_state"))
        if not self.calibratable:
            return bare
        wrapped = calibrator(estimator=bare, random_state=merged.get("random_state"), **calibration)
        return bare if wrapped.calibration in (None, "none") else wrapped


def _calibrator() -> type:
    """The calibrating meta-estimator every calibratable method is built inside."""
    return CalibratedZeroShotClassifier


def _constraints(method: Method) -> dict[str, list]:
    """The ``_parameter_constraints`` of the method's classes (and of its calibrator), first class first."""
    classes = [*method.components(), *([_calibrator()] if method.calibratable else [])]
    out: dict[str, list] = {}
    for cls in classes:
        for name, constraints in getattr(cls, "_parameter_constraints", {}).items():
            out.setdefault(name, list(constraints))
    return out


def _calibration_parameters() -> dict[str, object]:
    """The calibrator's own parameters and defaults (its ``estimator`` and ``random_state`` are the method's)."""
    return {k: v for k, v in _init_defaults(_calibrator()).items() if k not in ("estimator", "random_state")}


def register_method(
    name: str,
    attribute_model: type | None = None,
    *,
    family: str,
    paper: str,
    decision_rule: type | None = None,
    estimator: type | None = None,
    preset: Mapping[str, object] | None = None,
    description: str = "",
    replace: bool = False,
    input_ndim: int = 2,
    input_kind: str = "features",
    calibratable: bool | None = None,
    defaults: Mapping[str, object] | None = None,
):
    """Register a method; without a model class, return a class decorator that registers it.

    Parameters
    ----------
    name : str
    attribute_model : type, optional
        Attribute model class (with ``decision_rule``).
    family : str
        One of :data:`FAMILIES`.
    paper : str
    decision_rule : type, optional
        Decision rule class; required with an attribute model.
    estimator : type, optional
        Self-contained estimator class (instead of attribute model + rule).
    preset : mapping, optional
        Fixed parameters.
    description : str
    replace : bool, default=False
        Allow replacing a method of the same name.
    input_ndim : {2, 3}, default=2
        3 for methods fitted on per-sensor input ``(n_trials, n_sensors, n_features)``.
    input_kind : {"features", "grasps", "frames"}, default="features"
        What the method fits on (:data:`INPUT_KINDS`).
    calibratable : bool, optional
        Build it inside a :class:`~tzsl.models.CalibratedZeroShotClassifier` (the estimator must
        take ``fit(X, Y, groups)`` and ``decision_function(X, class_attributes)``). Default: True
        for attribute model + decision rule methods, False for self-contained estimators.
    defaults : mapping, optional
        Settable parameters whose default the method changes from its class's signature.

    Returns
    -------
    Method, or a decorator returning the class unchanged
    """
    if attribute_model is None and estimator is None:

        def decorator(cls: type) -> type:
            kw = {"estimator": cls} if decision_rule is None else {"attribute_model": cls}
            register_method(name, family=family, paper=paper, decision_rule=decision_rule, preset=preset,
                            description=description, replace=replace, input_ndim=input_ndim,
                            input_kind=input_kind, calibratable=calibratable, defaults=defaults, **kw)
            return cls

        return decorator
    if family not in FAMILIES:
        raise ConfigError(f"method {name!r}: family must be one of {FAMILIES}, got {family!r}")
    if (estimator is None) == (attribute_model is None) or (attribute_model is not None) != (decision_rule is not None):
        raise ConfigError(f"method {name!r}: give either attribute_model and decision_rule, or estimator")
    if input_ndim not in (2, 3):
        raise ConfigError(f"method {name!r}: input_ndim must be 2 or 3, got {input_ndim!r}")
    if input_kind not in INPUT_KINDS:
        raise ConfigError(f"method {name!r}: input_kind must be one of {INPUT_KINDS}, got {input_kind!r}")
    if name in _REGISTRY and not replace:
        raise ConfigError(f"method {name!r} is already registered")
    if name in _ALIASES:
        raise ConfigError(f"method {name!r}: the name is an alias of {_ALIASES[name][0]!r}")
    method = Method(name=name, family=family, paper=paper, attribute_model=attribute_model,
                    decision_rule=decision_rule, estimator=estimator,
                    preset=MappingProxyType(dict(preset or {})), description=description,
                    input_ndim=input_ndim, input_kind=input_kind,
                    calibratable=(estimator is None) if calibratable is None else bool(calibratable),
                    defaults=MappingProxyType(dict(defaults or {})))
    known = {k for c in method.components() for k in _init_defaults(c)}
    unknown = sorted((set(method.preset) | set(method.defaults)) - known)
    if unknown:
        raise ConfigError(f"method {name!r}: preset or defaults name unknown parameter(s) {unknown}")
    _REGISTRY[name] = method
    return method


def register_alias(name: str, method: str, *, preset: Mapping[str, object], replace: bool = False) -> None:
    """Register ``name`` as an alias of ``method`` with the parameters ``preset`` fixed.

    :func:`get_method` (and so :func:`build_method`, experiment files and ``--method``) accepts the
    alias; :func:`available_methods` does not list it (:func:`method_aliases` does).

    Parameters
    ----------
    name : str
        The alias (``"dap-avg-logistic-c1"``).
    method : str
        A registered method (not an alias).
    preset : mapping
        Settable parameters of ``method`` that the alias fixes, with accepted values.
    replace : bool, default=False
        Allow replacing an alias of the same name.

    Raises
    ------
    ConfigError
        ``name`` is a method or (without ``replace``) an alias already; ``method`` is unknown; a
        parameter of ``preset`` is not settable or its value not accepted.
    """
    if name in _REGISTRY:
        raise ConfigError(f"alias {name!r}: a method has that name")
    if name in _ALIASES and not replace:
        raise ConfigError(f"alias {name!r} is already registered (of {_ALIASES[name][0]!r})")
    if method not in _REGISTRY:
        raise ConfigError(f"alias {name!r}: {method!r} is not a registered method")
    target = _REGISTRY[method]
    unknown = sorted(set(preset) - set(target.parameters()))
    if unknown:
        raise ConfigError(f"alias {name!r}: {unknown} are not settable parameters of method {method!r}")
    problems = target.value_problems(preset)
    if problems:
        raise ConfigError(f"alias {name!r}: {next(iter(problems.values()))}")
    _ALIASES[name] = (method, MappingProxyType(dict(preset)))


def unregister_method(name: str) -> None:
    """Remove a method (e.g. a test's toy method) or an alias, and the aliases of a removed method."""
    _REGISTRY.pop(name, None)
    _ALIASES.pop(name, None)
    for alias in [a for a, (target, _) in _ALIASES.items() if target == name]:
        del _ALIASES[alias]


def get_method(name: str) -> Method:
    """The registered method called ``name``, or the configuration an alias names.

    An alias gives its method with the alias's name, its fixed parameters added to the method's
    ``preset`` (so they cannot be set again) and ``alias_of`` the method's name.

    Raises
    ------
    ConfigError
        No such method or alias (the message lists the known ones).
    """
    if name in _REGISTRY:
        return _REGISTRY[name]
    if name in _ALIASES:
        target, fixed = _ALIASES[name]
        method = _REGISTRY[target]
        return replace(method, name=name, alias_of=target, preset=MappingProxyType({**method.preset, **fixed}),
                       defaults=MappingProxyType({k: v for k, v in method.defaults.items() if k not in fixed}))
    raise ConfigError(f"unknown method {name!r}; known: {available_methods()}; aliases: {sorted(_ALIASES)}")


def available_methods() -> list[str]:
    """Names of every registered method, sorted (aliases left out: :func:`method_aliases`)."""
    return sorted(_REGISTRY)


def method_aliases() -> dict[str, dict[str, object]]:
    """Every alias as the method entry it names, sorted by alias.

    Returns
    -------
    dict
        ``{"dap-max": {"name": "dap", "fusion": "max", "prior": "uni"}, ...}``: the alias's method and
        the parameters it fixes (an entry :func:`build_method` and ``[methods] compare`` take).
    """
    return {alias: {"name": target, **fixed} for alias, (target, fixed) in sorted(_ALIASES.items())}


def build_method(name: str, **params) -> BaseEstimator:
    """``get_method(name).build(**params)``: an unfitted estimator of the named method."""
    return get_method(name).build(**params)


def all_estimators() -> list[tuple[str, type]]:
    """Every public estimator class of :mod:`tzsl.models`, like scikit-learn's ``all_estimators``.

    Decision rules are not estimators of trials (they fit attribute rows) and are left out.

    Returns
    -------
    list of (name, class), sorted by name
    """
    import tzsl.models as models  # noqa: PLC0415 (the package imports this module)

    out = []
    for name in models.__all__:
        obj = getattr(models, name)
        if (
            inspect.isclass(obj)
            and issubclass(obj, BaseEstimator)
            and not issubclass(obj, models.DecisionRule)
            and not inspect.isabstract(obj)
        ):
            out.append((name, obj))
    return sorted(out, key=lambda pair: pair[0])
