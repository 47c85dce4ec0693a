"""A set request as a caller writes it: a mapping of names to Python values, or Parameters.

:func:`to_parameters` is the one conversion every sender uses (the client's set, the
assigner's retained set): the request's size, each name and each value are checked here,
before anything is encoded or sent.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping

from .limits import check_request_size, check_value
from .names import validate_name
from .values import Parameter, ParameterValue

__all__ = ["ParamsArg", "to_parameters"]

ParamsArg = Mapping[str, object] | Iterable[Parameter]


def to_parameters(params: ParamsArg) -> list[Parameter]:
    """``params`` as a list of Parameters; raises TooLargeError, InvalidNameError or a
    value's size error before anything is sent."""
    if isinstance(params, Mapping):
        items = [Parameter(name, ParameterValue.from_python(v)) for name, v in params.items()]
    else:
        items = list(params)
    check_request_size(len(items))
    for p in items:
        validate_name(p.name)
        check_value(p.name, p.value)
    return items
