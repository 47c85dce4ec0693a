"""``paramdds bench codec``: encoding and decoding one sample, ours against the binding's.

In this process, no DDS traffic: for each case the same sample is encoded and
decoded by paramdds's codecs (the generated per-struct functions of
:mod:`paramdds.dds.cdr`, and the state fast paths of :mod:`paramdds.dds.state`)
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
from typing import Any

from ._common import emit, note, render


def _per_call_us(fn: Callable[[], object], calls: int) -> float:
    t0 = time.thread_time()
    for _ in range(calls):
        fn()
    return (time.thread_time() - t0) / calls * 1e6


def _cases() -> list[tuple[str, Callable[[], object], Callable[[], object], int]]:
    """(name, ours, the binding's, calls per round)."""
    from ..core.descriptors import ParameterDescriptor
    from ..core.values import ParameterType, ParameterValue
    from ..dds import types as wire
    from ..dds.cdr import decode, encode
    from ..dds.convert import value_to_wire
    from ..dds.state import decode_state, encode_state

    def value(v: object) -> Any:
        return value_to_wire(ParameterValue.from_python(v))

    stamp = wire.Time(1_700_000_000, 123_456_789)
    scalar = wire.ParameterEvent(
        node_id="robot_042", name="robot.max_velocity", revision=17, stamp=stamp, value=value(1.5)
    )
    rich = wire.ParameterEvent(
        node_id="robot_042",
        name="robot.gains",
        revision=17,
        stamp=stamp,
        value=value([1.0, 2.0, 3.0]),
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
    core_value, core_descriptor = ParameterValue.from_python(1.5), ParameterDescriptor(
        "robot.max_velocity", ParameterType.DOUBLE
    )

    def binding(sample: Any) -> tuple[Callable[[], object], Callable[[], object], bytes]:
        idl = type(sample).__idl__
        data = encode(sample)
        return (lambda: idl.serialize(sample)), (lambda: idl.deserialize(data)), data

    cases: list[tuple[str, Callable[[], object], Callable[[], object], int]] = []
    for label, sample, calls in (
        ("state sample", scalar, 4000),
        ("state, array + descriptor", rich, 2000),
        ("get reply of 10", reply, 500),
        ("set request of 10", request, 500),
    ):
        enc, dec, data = binding(sample)
        cases.append((f"encode {label}", partial(encode, sample), enc, calls))
        cases.append((f"decode {label}", partial(decode, type(sample), data), dec, calls))
    scalar_bytes = encode(scalar)
    enc, dec, _ = binding(scalar)
    cases.append(
        (
            "encode state, server fast path",
            lambda: encode_state("robot_042", "robot.max_velocity", 17, 1, 2, core_value, core_descriptor),
            enc,
            4000,
        )
    )
    cases.append(("decode state, monitor fast path", lambda: decode_state(scalar_bytes), dec, 4000))
    return cases


def run(args: argparse.Namespace) -> int:
    rounds = args.rounds or (2 if args.quick else 9)
    scale = 10 if args.quick else 1
    cases = _cases()
    note(f"codec: {len(cases)} cases, {rounds} alternating rounds, fastest round per side")
    best: dict[str, list[float]] = {name: [float("inf"), float("inf")] for name, *_ in cases}
    for _ in range(rounds):
        for name, ours, theirs, calls in cases:
            for side, fn in enumerate((ours, theirs)):
                best[name][side] = min(best[name][side], _per_call_us(fn, max(1, calls // scale)))
    rows = [(name, round(o, 2), round(t, 2), round(t / o, 1)) for name, (o, t) in best.items()]
    data = {
        "cases": [{"case": n, "paramdds_us": o, "binding_us": t, "speedup": x} for n, o, t, x in rows],
        "rounds": rounds,
    }
    emit(args, data, render(["case", "paramdds µs", "binding µs", "binding / paramdds"], rows))
    return 0
