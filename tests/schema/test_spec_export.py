"""A spec's exported schema rejects what the spec rejects, for the realworld
generate_parameter_library specs (../shared/realworld), with check-jsonschema as the judge.

For every parameter and every built-in validator JSON Schema can say, a parameter file
holding one value that breaks it is refused by the spec (paramdds's own validation) and
by check-jsonschema on the exported schema; a file holding each default the spec accepts
passes both. No DDS.
"""

from __future__ import annotations

import json
import math
import re
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

from paramdds.core.descriptors import ParameterDescriptor, Validator
from paramdds.core.validation import validate
from paramdds.core.values import ParameterType, ParameterValue
from paramdds.errors import ParamddsError
from paramdds.formats.schema.export import derive_schema
from paramdds.formats.spec import load_spec

from ..core.test_yaml_schema import REALWORLD, needs_realworld

T = ParameterType
SPECS = [
    "joint_trajectory_controller_parameters.yaml",
    "diff_drive_controller_parameter.yaml",
    "admittance_controller_parameters.yaml",
    "tricycle_controller_parameter.yaml",
]
CHECK_JSONSCHEMA = str(Path(sys.executable).with_name("check-jsonschema"))
_SAMPLE = {T.STRING_ARRAY: "s", T.INTEGER_ARRAY: 1, T.DOUBLE_ARRAY: 1.0, T.BOOL_ARRAY: True, T.STRING: "s"}


def _bump(x: Any, up: bool) -> Any:
    step = 1 if isinstance(x, int) else 1.0
    return x + step if up else x - step


def breaking(d: ParameterDescriptor, v: Validator) -> list[Any]:
    """Values (as JSON data) that break ``v`` on a ``d.type`` parameter."""
    args = [a.value for a in v.args]
    array = d.type.is_array
    sample = _SAMPLE.get(d.type, "s")
    k = v.kind
    if k == "bounds":
        return [_bump(args[1], True), _bump(args[0], False)]
    if k in ("lower_bounds", "gt_eq"):
        return [_bump(args[0], False)]
    if k in ("upper_bounds", "lt_eq"):
        return [_bump(args[0], True)]
    if k in ("gt", "lt"):
        return [args[0]]
    if k == "one_of":
        options = list(args[0])
        return ["zz_not_one_of"] if d.type is T.STRING else [max(options) + 1] if options else []
    if k in ("size_lt", "size_gt", "fixed_size"):
        n = int(args[0]) + (1 if k == "fixed_size" else 0)
        return [[sample] * n if array else "s" * n]
    if k == "not_empty":
        return [[] if array else ""]
    if k == "unique":
        return [[sample, sample]]
    if k == "subset_of":
        return [["zz_not_in"] if d.type is T.STRING_ARRAY else [max(args[0]) + 1]]
    if k == "element_bounds":
        return [[_bump(args[1], True)], [_bump(args[0], False)]]
    if k == "lower_element_bounds":
        return [[_bump(args[0], False)]]
    if k == "upper_element_bounds":
        return [[_bump(args[0], True)]]
    return []  # custom validators: text only


def _document(name: str, value: Any) -> str:
    params: dict[str, Any] = {}
    node = params
    parts = name.split(".")
    for part in parts[:-1]:
        node = node.setdefault(part, {})
    node[parts[-1]] = value
    return json.dumps({"/**": {"ros__parameters": params}})  # JSON is YAML


def _failing_files(schema: Path, files: list[Path]) -> set[str]:
    got = subprocess.run(
        [CHECK_JSONSCHEMA, "--schemafile", str(schema), *map(str, files)],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert "Traceback" not in got.stderr, got.stderr
    return {m.group(1) for m in re.finditer(r"^\s+(\S+\.yaml)::", got.stdout, re.M)}


@needs_realworld
@pytest.mark.parametrize("spec_name", SPECS)
def test_a_specs_exported_schema_rejects_what_the_spec_rejects(spec_name: str, tmp_path: Path) -> None:
    spec = load_spec(REALWORLD / spec_name)
    schema = derive_schema([(e.name, e.default, e.descriptor) for e in spec], title="node")
    schema_file = tmp_path / "node.schema.json"
    schema_file.write_text(json.dumps(schema))
    bad: list[Path] = []
    good: list[Path] = []
    for e in spec:
        d = e.descriptor
        for v in d.validators:
            for raw in breaking(d, v):
                value = ParameterValue.from_python(raw) if raw != [] else ParameterValue(d.type, ())
                with pytest.raises(ParamddsError):  # the spec refuses it...
                    validate(e.name, value.coerce(d.type), d)
                path = tmp_path / f"bad{len(bad)}.yaml"
                path.write_text(_document(e.name, raw))
                bad.append(path)
        default = e.default
        if default.type is not T.NOT_SET and all(
            not isinstance(x, float) or math.isfinite(x)
            for x in (default.value if isinstance(default.value, tuple) else (default.value,))
        ):
            try:
                validate(e.name, default, d)
            except ParamddsError:
                continue  # a default its own validators refuse (diff_drive's read-only ones)
            path = tmp_path / f"good{len(good)}.yaml"
            path.write_text(
                _document(e.name, list(default.value) if isinstance(default.value, tuple) else default.value)
            )
            good.append(path)
    assert len(bad) >= 3 and good
    failing = _failing_files(schema_file, bad + good)
    assert {str(p) for p in bad} - failing == set()  # ...and so does the exported schema
    assert {str(p) for p in good} & failing == set()
