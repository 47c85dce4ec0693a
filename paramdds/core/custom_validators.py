"""Custom spec validators: functions registered by name, as generate_parameter_library's ``ns::fn``.

A spec may name a validator that is not one of the built-ins
(``control_filters::gt_eq_or_nan<>: [0.0]``). In C++ that is a function the
package compiles in; here it is a Python function registered under the same name::

    from paramdds.core.custom_validators import register_validator

    def even(value, args):                     # ParameterValue, tuple[ParameterValue, ...]
        return None if value.value % 2 == 0 else "be even"

    register_validator("my_pkg::even", even)

The function returns ``None`` when the value passes, or the rule it breaks as a phrase
that follows "must" (``"be even"``), which becomes the error message. It must not raise;
if it does, the value is refused with the exception's text. ``paramdds server
--validators MODULE`` imports a module that registers its functions before the spec
is read.

A spec naming a validator that nobody registered still loads, with a warning naming
it; the validator is kept in the descriptor (``describe`` shows it among the
validators; ``additional_constraints`` stays the spec's own text, as in
generate_parameter_library). ``load_spec(...,
strict=True)`` (``--strict-spec``) refuses such a spec instead.

Shipped here, as ros2_controllers (``custom_validators.hpp``) and control_toolbox's
``control_filters`` define them, RSL's ``gt_eq``/``lt_eq`` checked only when the value
is not NaN:

* ``control_filters::gt_eq_or_nan`` ``[b]``: the value is NaN or ``>= b``;
* ``control_filters::lt_eq_or_nan`` ``[b]``: the value is NaN or ``<= b``.
"""

from __future__ import annotations

import math
import threading
from collections.abc import Callable

from ..errors import InvalidValueError
from .values import ParameterType, ParameterValue

__all__ = ["CustomCheck", "lookup_validator", "register_validator", "registered_validators"]

CustomCheck = Callable[[ParameterValue, tuple[ParameterValue, ...]], "str | None"]

_lock = threading.Lock()
_registry: dict[str, CustomCheck] = {}


def register_validator(name: str, check: CustomCheck, *, replace: bool = False) -> None:
    """Register ``check`` under ``name`` (``ns::fn``, written without ``<>``).

    Raises InvalidValueError for a name without ``::`` (built-in names cannot be
    replaced), a ``check`` that is not callable, or a name already taken (unless ``replace``).
    """
    if not isinstance(name, str) or "::" not in name or name.endswith("<>"):
        raise InvalidValueError(f"a custom validator is named 'namespace::function' without <>, got {name!r}")
    if not callable(check):
        raise InvalidValueError(f"custom validator {name!r} must be callable, got {type(check).__name__}")
    with _lock:
        if name in _registry and not replace:
            raise InvalidValueError(f"a custom validator {name!r} is already registered")
        _registry[name] = check


def lookup_validator(name: str) -> CustomCheck | None:
    """The function registered under ``name``, or None."""
    with _lock:
        return _registry.get(name)


def registered_validators() -> list[str]:
    """Every registered name, sorted."""
    with _lock:
        return sorted(_registry)


def _or_nan(lower: bool) -> CustomCheck:
    def check(value: ParameterValue, args: tuple[ParameterValue, ...]) -> str | None:
        if value.type not in (ParameterType.DOUBLE, ParameterType.INTEGER) or len(args) != 1:
            return "be a number, with one bound given"
        v, b = value.value, args[0].value
        assert isinstance(v, (int, float)) and isinstance(b, (int, float))
        if isinstance(v, float) and math.isnan(v):
            return None
        ok = v >= b if lower else v <= b
        return None if ok else f"be NaN or {'>=' if lower else '<='} {b}"

    return check


register_validator("control_filters::gt_eq_or_nan", _or_nan(lower=True))
register_validator("control_filters::lt_eq_or_nan", _or_nan(lower=False))
