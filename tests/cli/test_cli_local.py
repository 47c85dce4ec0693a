"""The CLI's local parts, without DDS: parsing, value typing, JSON shapes, persistence frames."""

from __future__ import annotations

import argparse
import ast
import json
import math
import subprocess
import sys
from pathlib import Path

import pytest

from paramdds.cli import main
from paramdds.cli._output import dumps_json
from paramdds.cli._parser import build_parser, resolve_globals
from paramdds.cli._values import fit_to_type, parse_assignment, parse_assignments
from paramdds.cli.verbs import CANONICAL, VERBS, verb
from paramdds.core.descriptors import FloatingPointRange, ParameterDescriptor, Validator
from paramdds.core.jsonform import json_descriptor, json_value
from paramdds.core.values import ParameterType, ParameterValue
from paramdds.errors import (
    CallTimeoutError,
    ConflictError,
    FileFormatError,
    NotFoundError,
    ReadOnlyError,
    TypeMismatchError,
    UnavailableError,
)
from paramdds.exits import Exit, UsageError, exit_code
from paramdds.persist import HEADER, PersistError, atomic_write, frame, unframe

PV = ParameterValue
T = ParameterType


# -- options -------------------------------------------------------------------------------


def _args(*argv: str, env: dict[str, str] | None = None) -> object:
    args = build_parser(argv).parse_args(list(argv))  # as main() parses: the named verb built alone
    assert vars(args) == vars(build_parser().parse_args(list(argv)))  # ... as the whole parser does
    resolve_globals(args, env or {})
    return args


@pytest.mark.parametrize(
    "argv",
    [
        ["-o", "json", "get", "n", "x"],
        ["--timeout", "2", "--localhost", "list", "n", "--depth", "1"],
        ["-q", "get", "set", "n", "x=1"],  # a QoS file named like a verb: the verb is `set`
        ["--zenoh=tcp/127.0.0.1:7447", "nodes"],
        ["get", "get", "nodes"],  # a node and a parameter named like verbs
        ["--log-level", "debug", "dump", "a", "b", "-d", "5"],
    ],
)
def test_the_parser_built_for_the_named_verb_parses_as_the_whole_parser(argv: list[str]) -> None:
    _args(*argv)


def test_top_level_help_lists_every_verb_with_its_help(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["-o", "json", "--help", "get"]) == Exit.OK
    out = " ".join(capsys.readouterr().out.split())  # argparse wraps the lines
    assert all(verb(name).HELP in out for name in VERBS), out
    assert main(["-o", "json", "get", "--help"]) == Exit.OK  # the verb's own help, globals included
    out = capsys.readouterr().out
    assert "NODE NAME [NAME ...]" in out and "--timeout SECONDS" in out, out


def test_global_options_before_or_after_the_verb() -> None:
    before = _args("-d", "7", "-o", "json", "--timeout", "2", "get", "n", "x")
    after = _args("get", "n", "x", "-d", "7", "-o", "json", "--timeout", "2")
    for a in (before, after):
        assert (a.domain, a.output, a.timeout) == (7, "json", 2.0)  # type: ignore[attr-defined]


def test_after_the_verb_wins_and_defaults_come_from_the_environment() -> None:
    a = _args("-d", "3", "list", "n", "-d", "4")
    assert a.domain == 4  # type: ignore[attr-defined]
    b = _args("list", "n", env={"PARAMDDS_DOMAIN": "9", "PARAMDDS_LOCALHOST": "1"})
    assert (b.domain, b.localhost, b.output) == (9, True, "table")  # type: ignore[attr-defined]
    c = _args("list", "n")
    assert (c.domain, c.localhost) == (1, False)  # type: ignore[attr-defined]


@pytest.mark.parametrize(
    "argv",
    [
        ["get", "n"],
        ["--bogus", "nodes"],
        ["set", "n", "x=1", "--if-revision", "abc"],
        ["nodes", "-o", "xml"],
        ["frobnicate"],
        ["list", "n", "-d", "999"],
        ["--zenoh", "tcp/127.0.0.1:7447", "get", "robot1", "x"],  # over Zenoh a node is SITE/NODE
    ],
)
def test_usage_errors_exit_2_with_one_line(argv: list[str], capsys: pytest.CaptureFixture[str]) -> None:
    assert main(argv) == Exit.USAGE
    err = capsys.readouterr().err
    assert err.startswith("paramdds: error: ") and err.count("\n") == 1


def test_help_does_not_import_cyclonedds() -> None:
    code = (
        "import sys\nfrom paramdds.cli import main\n"
        "try:\n    main(['--help'])\nexcept SystemExit:\n    pass\n"
        "rc = main(['get', '--help'])\n"
        "assert 'cyclonedds' not in sys.modules, sorted(m for m in sys.modules if 'cyclone' in m)\n"
        "print('ok', rc)\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=30)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip().endswith("ok 0")


def test_every_verb_is_one_module_with_its_help_arguments_and_run() -> None:
    parser = build_parser()
    verbs = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    assert [c for c in verbs.choices if c not in CANONICAL] == list(VERBS)
    assert {c for c in verbs.choices if c in CANONICAL} == set(CANONICAL)  # aliases
    for name in VERBS:
        module = verb(name)
        assert isinstance(module.HELP, str) and module.HELP, name
        assert callable(module.add_arguments) and callable(module.run), name


def test_the_server_verbs_history_defaults_are_the_cores() -> None:
    from paramdds.cli.verbs import server
    from paramdds.core.history import Retention

    assert Retention().max_records == server.HISTORY_RECORDS
    assert Retention().max_age_s == server.HISTORY_DAYS * 86400


def test_help_imports_the_verbs_and_nothing_they_run() -> None:
    # a verb's module imports argparse at its top, everything else in run()
    code = (
        "import sys\nfrom paramdds.cli import main\n"
        "try:\n    main(['--help'])\nexcept SystemExit:\n    pass\n"
        "print(sorted(m for m in sys.modules if m.startswith(('paramdds.', 'yaml'))))\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=30)
    assert out.returncode == 0, out.stderr
    loaded = set(ast.literal_eval(out.stdout.strip().splitlines()[-1]))
    light = {"paramdds._lazy", "paramdds.core", "paramdds.errors", "paramdds.exits"}
    assert {m for m in loaded if not m.startswith("paramdds.cli")} <= light


# -- NAME=VALUE ---------------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("arg", "value"),
    [
        ("a=1", PV(T.INTEGER, 1)),
        ("a=1.5", PV(T.DOUBLE, 1.5)),
        ("a=true", PV(T.BOOL, True)),
        ("a=[1, 2]", PV.of(T.INTEGER_ARRAY, [1, 2])),
        ('a="on"', PV(T.STRING, "on")),
        ("a=abc def", PV(T.STRING, "abc def")),
        ("a.b=x=y", PV(T.STRING, "x=y")),
    ],
)
def test_values_are_typed_like_yaml_scalars(arg: str, value: ParameterValue) -> None:
    a = parse_assignment(arg)
    assert a.value is not None and a.value.same_as(value)


@pytest.mark.parametrize("arg", ["novalue", "=1", "a b=1", "a=[1, 2", "a=[1, 2.5]", "a..b=1"])
def test_bad_assignments_are_usage_errors(arg: str) -> None:
    with pytest.raises(UsageError):
        parse_assignment(arg)


def test_a_name_given_twice_is_a_usage_error() -> None:
    with pytest.raises(UsageError, match="twice"):
        parse_assignments(["a=1", "a=2"])


def test_empty_lists_and_byte_arrays_take_the_nodes_type() -> None:
    empty = parse_assignment("a=[]")
    assert empty.value is None
    assert fit_to_type(empty, T.DOUBLE_ARRAY).same_as(PV.of(T.DOUBLE_ARRAY, []))
    with pytest.raises(NotFoundError):
        fit_to_type(empty, None)
    with pytest.raises(TypeMismatchError):
        fit_to_type(empty, T.DOUBLE)
    ints = parse_assignment("b=[1, 255]")
    assert fit_to_type(ints, T.BYTE_ARRAY).same_as(PV(T.BYTE_ARRAY, b"\x01\xff"))
    with pytest.raises(UsageError):
        fit_to_type(parse_assignment("b=[1, 256]"), T.BYTE_ARRAY)


# -- JSON shapes --------------------------------------------------------------------------------


def test_json_value_shapes() -> None:
    shapes = {
        "d": json_value(PV(T.DOUBLE, 2.0)),
        "n": json_value(PV(T.DOUBLE, math.nan)),
        "i": json_value(PV(T.DOUBLE, math.inf)),
        "m": json_value(PV(T.DOUBLE, -math.inf)),
        "b": json_value(PV(T.BYTE_ARRAY, b"\x00\x07\xff")),
        "da": json_value(PV.of(T.DOUBLE_ARRAY, [1.0, math.nan])),
        "s": json_value(PV(T.STRING, "x")),
        "t": json_value(PV(T.BOOL, True)),
        "k": json_value(PV(T.INTEGER, 2)),
    }
    text = dumps_json(shapes, pretty=False)
    assert text == (
        '{"d": 2.0, "n": "nan", "i": "inf", "m": "-inf", "b": [0, 7, 255], "da": [1.0, "nan"], '
        '"s": "x", "t": true, "k": 2}'
    )


def test_json_descriptor_shape() -> None:
    d = ParameterDescriptor(
        "v",
        T.DOUBLE,
        description="top speed",
        floating_point_range=FloatingPointRange(0.0, 5.0, 0.0),
        validators=(Validator("bounds", (PV(T.DOUBLE, 0.0), PV(T.DOUBLE, 5.0))),),
    )
    assert json.loads(dumps_json(json_descriptor(d))) == {
        "type": "double",
        "description": "top speed",
        "read_only": False,
        "dynamic_typing": False,
        "integer_range": None,
        "floating_point_range": {"from_value": 0.0, "to_value": 5.0, "step": 0.0},
        "additional_constraints": "",
        "validators": [{"kind": "bounds", "args": [0.0, 5.0]}],
    }


def test_exit_codes_are_mapped_by_error_code() -> None:
    assert exit_code(CallTimeoutError("x")) == 3
    assert exit_code(UnavailableError("x")) == 3
    assert exit_code(FileFormatError("x", file="f", line=2)) == 2
    for exc in (NotFoundError("x"), ReadOnlyError("x"), ConflictError("x"), TypeMismatchError("x")):
        assert exit_code(exc) == 1
    assert exit_code(KeyboardInterrupt()) == 130
    assert exit_code(UsageError("x")) == 2


# -- persistence frames ---------------------------------------------------------------------------


BODY = "robot1:\n  ros__parameters:\n    a: 1\n"


def test_a_framed_file_round_trips_and_damage_is_detected(tmp_path: Path) -> None:
    text = frame(BODY)
    assert unframe(text.encode(), "f") == HEADER + BODY
    with pytest.raises(PersistError, match="truncated"):
        unframe(text.encode()[: len(text) - 20], "f")
    with pytest.raises(PersistError, match="checksum"):
        unframe(text.replace("a: 1", "a: 2").encode(), "f")
    with pytest.raises(PersistError, match="empty"):
        unframe(b"", "f")
    with pytest.raises(PersistError, match="UTF-8"):
        unframe(b"\xff\xfe", "f")
    with pytest.raises(PersistError, match="not a paramdds persistence file"):
        unframe(BODY.encode(), "f")  # a hand-written ROS 2 file: refused, never rewritten


def test_atomic_write_replaces_and_leaves_no_temporary_file(tmp_path: Path) -> None:
    path = tmp_path / "state.yaml"
    atomic_write(path, "one\n")
    atomic_write(path, "two\n")
    assert path.read_text() == "two\n"
    assert [p.name for p in tmp_path.iterdir()] == ["state.yaml"]
