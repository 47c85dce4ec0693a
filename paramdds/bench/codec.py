"""``paramdds bench codec``: encoding and decoding one sample, ours against the binding's.

In this process, no DDS traffic: for each case the same sample is encoded and
decoded by paramdds's codecs (the generated per-struct functions of
:mod:`paramdds.dds.wire.cdr`, and the state fast paths of :mod:`paramdds.dds.wire.state`)
and by cyclonedds-python's own generic interpreter, the baseline, alternating
in rounds. Times are CPU time of this thread (``time.thread_time``), so the
time other processes take the core from us is not counted, and the fastest
round is reported: on a shared machine both are far steadier than wall time.
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Callable
from functools import partial
from typing import Any, NamedTuple

from ._common import emit, note, render

# a server's state samples carry the node's incarnation and their change's blame
INCARNATION = 0x1234_5678_9ABC_DEF0
BLAME: dict[str, Any] = {"who": "alice@robot-host", "verified": False, "via": "cli"}
STATE_TAIL = (INCARNATION, *BLAME.values())  # encode_state's arguments after the descriptor


def _per_call_us(fn: Callable[[], object], calls: int) -> float:
    t0 = time.thread_time()
    for _ in range(calls):
        fn()
    return (time.thread_time() - t0) / calls * 1e6


class _Case(NamedTuple):
    name: str
    ours: Callable[[], object]
    theirs: Callable[[], object]  # the binding's
    calls: int  # per round
    per_call: int = 1  # samples each call handles (times are reported per sample)


def _cases() -> list[_Case]:
    from ..core.descriptors import ParameterDescriptor
    from ..core.values import ParameterType, ParameterValue
    from ..dds.wire import types as wire
    from ..dds.wire.cdr import decode, encode
    from ..dds.wire.convert import value_to_wire
    from ..dds.wire.state import decode_state, encode_state

    def value(v: object) -> Any:
        return value_to_wire(ParameterValue.from_python(v))

    stamp = wire.Time(1_700_000_000, 123_456_789)
    scalar = wire.ParameterEvent(
        node_id="robot_042",
        name="robot.max_velocity",
        revision=17,
        stamp=stamp,
        value=value(1.5),
        incarnation=INCARNATION,
        **BLAME,
    )
    rich = wire.ParameterEvent(
        node_id="robot_042",
        name="robot.gains",
        revision=17,
        stamp=stamp,
        value=value([1.0, 2.0, 3.0]),
        incarnation=INCARNATION,
        **BLAME,
        descriptor=[
            wire.ParameterDescriptor(
                name="robot.gains",
                type=int(ParameterType.DOUBLE_ARRAY),
                description="PID gains",
                floating_point_range=[wire.FloatingPointRange(0.0, 10.0, 0.0)],
            )
        ],
    )
    reply = wire.GetParametersResponse(
        node_id="robot_042",
        client_id=2**63,
        request_id=5,
        revision=3,
        results=[wire.GetParameterResult(name=f"p{i}", value=value(float(i))) for i in range(10)],
    )
    request = wire.SetParametersRequest(
        node_id="robot_042",
        client_id=2**63,
        request_id=5,
        parameters=[wire.Parameter(name=f"p{i}", value=value(float(i))) for i in range(10)],
    )
    core_value, core_descriptor = (
        ParameterValue.from_python(1.5),
        ParameterDescriptor("robot.max_velocity", ParameterType.DOUBLE),
    )

    def binding(sample: Any) -> tuple[Callable[[], object], Callable[[], object], bytes]:
        idl = type(sample).__idl__
        data = encode(sample)
        return (lambda: idl.serialize(sample)), (lambda: idl.deserialize(data)), data

    cases: list[_Case] = []
    for label, sample, calls in (
        ("state sample", scalar, 4000),
        ("state, array + descriptor", rich, 2000),
        ("get reply of 10", reply, 500),
        ("set request of 10", request, 500),
    ):
        enc, dec, data = binding(sample)
        cases.append(_Case(f"encode {label}", partial(encode, sample), enc, calls))
        cases.append(_Case(f"decode {label}", partial(decode, type(sample), data), dec, calls))
    scalar_bytes = encode(scalar)
    enc, dec, _ = binding(scalar)
    cases.append(
        _Case(
            "encode state, server fast path",
            lambda: encode_state(
                "robot_042", "robot.max_velocity", 17, 1, 2, core_value, core_descriptor, *STATE_TAIL
            ),
            enc,
            4000,
        )
    )
    cases.append(_Case("decode state, monitor fast path", lambda: decode_state(scalar_bytes), dec, 4000))
    rich_state = decode_state(encode(rich))
    gains, gains_descriptor = rich_state.value, rich_state.descriptor
    enc, dec, rich_bytes = binding(rich)
    cases.append(
        _Case(
            "encode state, array + descriptor, server",
            lambda: encode_state("robot_042", "robot.gains", 17, 1, 2, gains, gains_descriptor, *STATE_TAIL),
            enc,
            2000,
        )
    )
    cases.append(
        _Case("decode state, array + descriptor, monitor", lambda: decode_state(rich_bytes), dec, 2000)
    )
    return cases + _bench_set_cases()


def _bench_set_cases() -> list[_Case]:
    """The server and monitor paths over the 20 parameters of a bench node (descriptions,
    ranges, validators, arrays in real files' proportions: see ``worker.descriptor_for``)."""
    from ..dds.wire import types as wire
    from ..dds.wire.cdr import encode
    from ..dds.wire.convert import state_descriptor_to_wire, value_to_wire
    from ..dds.wire.state import decode_state, encode_state
    from .worker import make_table

    table = make_table("robot_042", 20)
    args = [
        ("robot_042", n, 17, 1, 2, table.get(n), table.describe_one(n), *STATE_TAIL) for n in table.names()
    ]
    samples = [
        wire.ParameterEvent(
            node_id=node,
            name=name,
            revision=revision,
            stamp=wire.Time(sec, nanosec),
            value=value_to_wire(value),
            descriptor=state_descriptor_to_wire(descriptor, value),
            incarnation=INCARNATION,
            **BLAME,
        )
        for node, name, revision, sec, nanosec, value, descriptor, *_ in args
    ]
    datas = [encode(s) for s in samples]
    idl = wire.ParameterEvent.__idl__

    def ours_encode() -> None:
        for a, sample in zip(args, samples, strict=True):
            if encode_state(*a) is None:  # as the server does: the generated encoder then
                encode(sample)

    def ours_decode() -> None:
        for data in datas:
            decode_state(data)

    def theirs_encode() -> None:
        for sample in samples:
            idl.serialize(sample)

    def theirs_decode() -> None:
        for data in datas:
            idl.deserialize(data)

    return [
        _Case("encode state, bench node's 20 params, server", ours_encode, theirs_encode, 200, len(args)),
        _Case("decode state, bench node's 20 params, monitor", ours_decode, theirs_decode, 200, len(args)),
    ]


def _sizes() -> dict[str, int]:
    """The bytes a server writes for a typical parameter's state sample (header and padding
    included): a scalar with a plain descriptor, and the same without its blame."""
    from ..core.descriptors import ParameterDescriptor
    from ..core.values import ParameterType, ParameterValue
    from ..dds.wire.state import encode_state

    value = ParameterValue.from_python(1.5)
    d = ParameterDescriptor("robot.max_velocity", ParameterType.DOUBLE)
    sizes = {}
    for label, tail in (("with blame", STATE_TAIL), ("blame empty", (INCARNATION,))):
        data = encode_state("robot_042", "robot.max_velocity", 17, 1, 2, value, d, *tail)
        assert data is not None
        sizes[label] = len(data)
    return sizes


def run(args: argparse.Namespace) -> int:
    rounds = args.rounds or (2 if args.quick else 9)
    scale = 10 if args.quick else 1
    cases = _cases()
    note(f"codec: {len(cases)} cases, {rounds} alternating rounds, fastest round per side")
    best: dict[str, list[float]] = {case.name: [float("inf"), float("inf")] for case in cases}
    for _ in range(rounds):
        for case in cases:
            for side, fn in enumerate((case.ours, case.theirs)):
                us = _per_call_us(fn, max(1, case.calls // scale)) / case.per_call
                best[case.name][side] = min(best[case.name][side], us)
    rows = [(name, round(o, 2), round(t, 2), round(t / o, 1)) for name, (o, t) in best.items()]
    sizes = _sizes()
    data = {
        "cases": [{"case": n, "paramdds_us": o, "binding_us": t, "speedup": x} for n, o, t, x in rows],
        "rounds": rounds,
        "state_sample_bytes": sizes,
    }
    note("state sample of a scalar parameter, bytes: " + ", ".join(f"{k} {v}" for k, v in sizes.items()))
    emit(args, data, render(["case", "paramdds µs", "binding µs", "binding / paramdds"], rows))
    return 0
