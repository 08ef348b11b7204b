"""Parameter validation the scikit-learn way, with tzsl's one-line error for the command line.

Every tzsl estimator declares its parameters in ``_parameter_constraints`` (scikit-learn's
:mod:`sklearn.utils._param_validation` vocabulary: ``Interval``, ``StrOptions``, ``HasMethods``,
...) and validates them at the start of ``fit`` through :class:`ValidatedParamsMixin`. A bad
value raises :class:`ParameterError`, which is both scikit-learn's ``InvalidParameterError``
(so ``check_estimator`` and scikit-learn users see what they expect) and a
:class:`tzsl.exceptions.ConfigError` (so ``tzsl`` commands print one line, never a traceback).
"""

from __future__ import annotations

from sklearn.utils._param_validation import InvalidParameterError

from tzsl.exceptions import ConfigError

__all__ = ["ParameterError", "ValidatedParamsMixin"]


class ParameterError(ConfigError, InvalidParameterError):
    """A parameter of a tzsl estimator has a wrong type or value.

    A :class:`tzsl.exceptions.ConfigError` and scikit-learn's ``InvalidParameterError`` (itself a
    ``ValueError`` and ``TypeError``).
    """


class ValidatedParamsMixin:
    """``_validate_params`` raising :class:`ParameterError`; put it before ``BaseEstimator``.

    Subclasses declare ``_parameter_constraints`` and may add ``_check_param_values(self)`` for
    checks across parameters (raise :class:`ParameterError` there).
    """

    def _validate_params(self) -> None:
        try:
            super()._validate_params()  # type: ignore[misc]
        except InvalidParameterError as exc:
            if isinstance(exc, ParameterError):
                raise
            raise ParameterError(str(exc)) from None
        check = getattr(self, "_check_param_values", None)
        if check is not None:
            check()
