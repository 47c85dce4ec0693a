"""The state decoder and encoder against the generated codec: same result, or both refuse.

``decode_state`` reads any well-formed state sample in one pass and hands everything
else to ``decode_state_slowly`` (the generated codec and the wire→core conversions).
Whatever the bytes, the fast path may only return what the slow one returns (same
types and float bits: compared through ``canonical``); it must actually be taken for
every shape a server writes, generated and real-world; and bytes that are no sample
raise ``MalformedSample`` instead of reaching a monitor's table. ``encode_state`` must
write exactly the generated encoder's bytes, or decline.
"""

import math
import struct
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from paramdds.core.descriptors import FloatingPointRange, IntegerRange, ParameterDescriptor, Validator
from paramdds.core.values import NOT_SET, ParameterType, ParameterValue
from paramdds.dds._binding import Endianness
from paramdds.dds.wire import state
from paramdds.dds.wire import types as wire
from paramdds.dds.wire.cdr import MalformedSample, encode
from paramdds.dds.wire.convert import is_plain, state_descriptor_to_wire, value_to_wire
from paramdds.dds.wire.state import _decode_fast, decode_state, decode_state_slowly, encode_state
from paramdds.formats.ros import load_ros_params
from paramdds.formats.spec import load_spec

from .strategies import StateArgs, canonical, samples, state_args

_KEY = st.text(st.characters(exclude_categories=("Cs",)), min_size=0, max_size=40).filter(
    lambda s: len(s.encode()) <= 255
)
_BLAME = st.one_of(st.sampled_from(["", "alice@robot-host", "cli"]), _KEY)  # who, via
_SCALARS = st.one_of(
    st.booleans(),
    st.integers(-(2**63), 2**63 - 1),
    st.floats(allow_nan=False),
    st.text(st.characters(exclude_categories=("Cs",)), max_size=30),
)


@st.composite
def common_samples(draw: st.DrawFn) -> wire.ParameterEvent:
    """The shapes almost every state sample has: a scalar parameter with a plain
    descriptor, or a node's presence."""
    presence = draw(st.booleans())
    return wire.ParameterEvent(
        node_id=draw(_KEY),
        name="" if presence else draw(_KEY),
        kind=wire.EVENT_PRESENCE if presence else wire.EVENT_PARAMETER,
        revision=draw(st.integers(-(2**63), 2**63 - 1)),
        stamp=wire.Time(draw(st.integers(-(2**31), 2**31 - 1)), draw(st.integers(0, 999_999_999))),
        value=value_to_wire(NOT_SET if presence else ParameterValue.from_python(draw(_SCALARS))),
        host=draw(_KEY),
        pid=draw(st.integers(-(2**31), 2**31 - 1)),
        parameter_count=draw(st.integers(0, 2**32 - 1)),
        incarnation=draw(st.integers(0, 2**64 - 1)),
        who=draw(_BLAME),
        verified=draw(st.booleans()),
        via=draw(_BLAME),
    )


def _event(name: str, value: object) -> wire.ParameterEvent:
    return wire.ParameterEvent(node_id="n", name=name, value=value_to_wire(ParameterValue.from_python(value)))


def _same(data: bytes) -> None:
    """decode_state(data) returns what the slow path returns, or both refuse."""
    try:
        expected = decode_state_slowly(data)
    except MalformedSample:
        with pytest.raises(MalformedSample):
            decode_state(data)
        return
    assert canonical(decode_state(data)) == canonical(expected)


def _wire(a: StateArgs, **tail: object) -> wire.ParameterEvent:
    """The wire sample a server writes for ``a`` (what the generated encoder is given)."""
    return wire.ParameterEvent(
        node_id=a.node_id,
        name=a.name,
        revision=a.revision,
        stamp=wire.Time(a.sec, a.nanosec),
        value=value_to_wire(a.value),
        descriptor=state_descriptor_to_wire(a.descriptor, a.value),
        incarnation=a.incarnation,
        who=a.who,
        verified=a.verified,
        via=a.via,
        **tail,
    )


def _sent(a: StateArgs) -> ParameterDescriptor:
    """The descriptor a reader gets: a plain one is left out and rebuilt from the sample's name."""
    return ParameterDescriptor(a.name, a.value.type) if is_plain(a.descriptor, a.value) else a.descriptor


def _first_difference(a: bytes, b: bytes) -> int:
    return next(i for i, (x, y) in enumerate(zip(a, b, strict=False)) if x != y)


@settings(max_examples=300, deadline=None)
@given(common_samples())
def test_the_common_shapes_take_the_fast_path_and_agree(sample: wire.ParameterEvent) -> None:
    data = encode(sample)
    fast = _decode_fast(data)
    assert fast is not None
    assert canonical(fast) == canonical(decode_state_slowly(data))
    ptype = ParameterType(sample.value.type)
    expected = None if ptype is ParameterType.NOT_SET else getattr(sample.value, f"{ptype.label}_value")
    assert (fast.node_id, fast.name, fast.kind, fast.value.value) == (
        sample.node_id,
        sample.name,
        sample.kind,
        expected,
    )
    assert (fast.host, fast.pid, fast.parameter_count) == (sample.host, sample.pid, sample.parameter_count)
    assert fast.incarnation == sample.incarnation
    assert (fast.who, fast.verified, fast.via) == (sample.who, sample.verified, sample.via)
    assert fast.descriptor == ParameterDescriptor(sample.name, ptype)


@settings(max_examples=400, deadline=None)
@given(
    args=state_args(),
    kind=st.sampled_from([wire.EVENT_PARAMETER, wire.EVENT_PRESENCE]),
    host=_KEY,
    pid=st.integers(-(2**31), 2**31 - 1),
)
def test_every_well_formed_sample_takes_the_fast_path_and_agrees(
    args: StateArgs, kind: int, host: str, pid: int
) -> None:
    data = encode(_wire(args, kind=kind, host=host, pid=pid, parameter_count=len(host)))
    slow = decode_state_slowly(data)
    for _ in range(2):  # the second time, the descriptor comes from the cache
        fast = _decode_fast(data)
        assert fast is not None
        assert canonical(fast) == canonical(slow)
    assert canonical((fast.value, fast.descriptor)) == canonical((args.value, _sent(args)))
    assert (fast.node_id, fast.name, fast.kind) == (args.node_id, args.name, kind)
    assert (fast.revision, fast.incarnation) == (args.revision, args.incarnation)
    assert (fast.who, fast.verified, fast.via) == (args.who, args.verified, args.via)
    assert (fast.host, fast.pid, fast.parameter_count) == (host, pid, len(host))


@settings(max_examples=200, deadline=None)
@given(samples(wire.ParameterEvent))
def test_any_sample_decodes_as_the_generated_codec_does(sample: wire.ParameterEvent) -> None:
    _same(encode(sample))


@settings(max_examples=500, deadline=None)
@given(
    sample=st.one_of(common_samples(), state_args().map(_wire)),
    cut=st.integers(0, 400),
    flips=st.lists(st.tuples(st.integers(0, 400), st.integers(1, 255)), max_size=4),
)
def test_damaged_bytes_never_decode_differently(
    sample: wire.ParameterEvent, cut: int, flips: list[tuple[int, int]]
) -> None:
    data = bytearray(encode(sample))
    for i, mask in flips:
        if i < len(data):
            data[i] ^= mask
    _same(bytes(data[: max(0, len(data) - cut)]))


def _described(descriptor: ParameterDescriptor, value: object = 1.5) -> wire.ParameterEvent:
    v = ParameterValue.from_python(value)
    return _wire(StateArgs("n", descriptor.name, 1, 0, 0, v, descriptor))


def test_what_the_fast_path_leaves_to_the_slow_one() -> None:
    ranged = ParameterDescriptor(
        "speed", ParameterType.DOUBLE, "m/s", floating_point_range=FloatingPointRange(0.0, 5.0)
    )
    sample = _described(ranged)
    assert _decode_fast(encode(sample)) is not None  # positive control: this shape is read fast
    big = bytes(wire.ParameterEvent.__idl__.serialize(sample, endianness=Endianness.Big))
    xcdr2 = bytes(wire.ParameterEvent.__idl__.serialize(sample, use_version_2=True))
    beside = _event("a", 1)  # a foreign writer's non-empty sequence beside the value's own
    beside.value.string_array_value = ["x"]
    for what, data in {"big endian": big, "XCDR2": xcdr2, "beside": encode(beside)}.items():
        assert _decode_fast(data) is None, what
        assert canonical(decode_state(data)) == canonical(decode_state_slowly(data)), what
    assert decode_state(big).descriptor == ranged
    assert decode_state(encode(beside)).value == ParameterValue.from_python(1)


def test_bounds_and_unknown_type_bytes_are_malformed() -> None:
    """Each damage is placed where two valid samples first differ: a descriptor or a range
    sequence of two (bound 1), a type byte of 42 in the descriptor and in a validator's argument."""
    v, integer = ParameterValue.from_python, ParameterType.INTEGER
    one, true = v(1), v(True)

    def described(**fields: object) -> wire.ParameterEvent:
        return _described(ParameterDescriptor("p", **fields), 1)  # type: ignore[arg-type]

    base = described(type=integer, validators=(Validator("gt", (one,)),))
    cases = {
        "descriptors": (described(type=integer), base, 2),
        "range": (base, described(type=integer, integer_range=IntegerRange(0, 9)), 2),
        "descriptor type": (base, described(type=ParameterType.BOOL), 42),
        "argument type": (base, described(type=integer, validators=(Validator("gt", (true,)),)), 42),
    }
    for what, (a, b, byte) in cases.items():
        data_a, data_b = encode(a), encode(b)
        assert _decode_fast(data_a) is not None and _decode_fast(data_b) is not None, what
        damaged = bytearray(data_a)
        damaged[_first_difference(data_a, data_b)] = byte
        assert _decode_fast(bytes(damaged)) is None, what
        with pytest.raises(MalformedSample):
            decode_state(bytes(damaged))


def test_presence_and_a_parameter_without_value() -> None:
    presence = wire.ParameterEvent(
        node_id="n", kind=wire.EVENT_PRESENCE, revision=7, host="h", pid=42, parameter_count=3
    )
    got = decode_state(encode(presence))
    assert (got.kind, got.revision, got.host, got.pid, got.parameter_count, got.value) == (
        wire.EVENT_PRESENCE,
        7,
        "h",
        42,
        3,
        NOT_SET,
    )
    assert decode_state(encode(wire.ParameterEvent(node_id="n", name="gone"))).value is NOT_SET


def test_big_endian_and_special_doubles() -> None:
    for d in (math.inf, -math.inf, -0.0, 5e-324):
        sample = _event("d", d)
        got = decode_state(encode(sample))
        assert got.value.value == d and math.copysign(1, got.value.value) == math.copysign(1, d)
        big = bytes(wire.ParameterEvent.__idl__.serialize(sample, endianness=Endianness.Big))
        assert decode_state(big) == got  # another encoding: the binding reads it, same result
    assert math.isnan(decode_state(encode(_event("d", math.nan))).value.value)  # type: ignore[arg-type]


def test_shared_scalar_values_keep_their_exact_type_and_sign() -> None:
    """Scalar values are shared by their bytes: values equal in Python but not on the wire
    (0.0 and -0.0, 1 and 1.0 and True) must each come back as they were sent, however often."""
    values = [0.0, -0.0, 1, 1.0, True, "1", 0, False, -0.0, 0.0]
    for _ in range(2):  # the second round reads them from the cache
        for v in values:
            got = decode_state(encode(_event("x", v))).value
            assert type(got.value) is type(v) and got.value == v, (v, got)
            if isinstance(v, float):
                assert math.copysign(1, got.value) == math.copysign(1, v)  # type: ignore[arg-type]
    assert state._values  # positive control: the cache is in use


def test_what_is_refused() -> None:
    good = encode(_event("p", 1))
    # header, "n", "p" (each length + text + padding), kind + padding to 8 after the header,
    # revision, Time {sec, nanosec}: the value's type byte is at offset 36
    unknown_type = bytearray(good)
    assert unknown_type[36] == ParameterType.INTEGER
    unknown_type[36] = 42
    for bad in (good[:-4], good[:20], b"", bytes(unknown_type), good.replace(b"p\x00", b"\xff\x00")):
        with pytest.raises(MalformedSample):
            decode_state(bad)


def _check_encoding(a: StateArgs) -> bytes:
    """encode_state(a) is the generated encoder's bytes (also from its cache), and reads back."""
    expected = encode(_wire(a))
    for _ in range(2):  # the second time, the descriptor's bytes come from the cache
        got = encode_state(*a)
        assert got is not None
        assert got == expected + bytes(-len(expected) % 4)  # padded as DataWriter.write pads
    fast = _decode_fast(got)
    assert fast is not None
    assert canonical((fast.value, fast.descriptor)) == canonical((a.value, _sent(a)))
    assert (fast.who, fast.verified, fast.via) == (a.who, a.verified, a.via)
    return got


@settings(max_examples=400, deadline=None)
@given(state_args())
def test_a_servers_state_sample_is_encoded_as_the_generated_encoder_does(args: StateArgs) -> None:
    _check_encoding(args)


def test_descriptors_equal_but_for_the_sign_of_zero_are_encoded_apart() -> None:
    """0.0 == -0.0, so an encoded-descriptor cache keyed on equality could mix them up."""
    v, double = ParameterValue.from_python, ParameterType.DOUBLE
    for zero in (0.0, -0.0, 0.0):
        for d in (
            ParameterDescriptor("p", double, floating_point_range=FloatingPointRange(zero, 1.0)),
            ParameterDescriptor("p", double, validators=(Validator("gt", (v(zero),)),)),
            ParameterDescriptor("p", double, validators=(Validator("one_of", (v([1.0, zero]),)),)),
        ):
            _check_encoding(StateArgs("n", "p", 1, 0, 0, v(zero), d))


def test_the_descriptor_caches_stay_bounded_and_right(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(state, "_CACHE_MAX", 3)
    monkeypatch.setattr(state, "_decoded", tuple({} for _ in range(8)))  # one per alignment, empty
    monkeypatch.setattr(state, "_encoded", {})
    v = ParameterValue.from_python(1.5)
    descriptors = [ParameterDescriptor("p", ParameterType.DOUBLE, f"described {i}") for i in range(7)]
    descriptors.append(ParameterDescriptor("p", ParameterType.DOUBLE, "long " * 300))  # over 1 KB: never kept
    for _ in range(2):
        for d in descriptors:
            got = _check_encoding(StateArgs("n", "p", 1, 0, 0, v, d))
            assert canonical(decode_state(got)) == canonical(decode_state_slowly(got))
            assert all(len(cache) <= 3 for cache in (*state._decoded, state._encoded))
    assert all(len(data) <= 1024 for cache in state._decoded for seen in cache.values() for data, _ in seen)


def test_what_the_state_encoder_leaves_to_the_generated_one() -> None:
    one = ParameterValue.from_python(1)
    plain = ParameterDescriptor("a", ParameterType.INTEGER)
    assert encode_state("n", "a", 2**63 - 1, 0, 0, one, plain) is not None  # positive control
    assert encode_state("x" * 256, "a", 1, 0, 0, one, plain) is None  # over the key's bound
    assert encode_state("n", "a", 2**63, 0, 0, one, plain) is None  # over int64
    assert encode_state("n", "\ud800", 1, 0, 0, one, plain) is None  # no UTF-8 for it
    listed = ParameterValue(ParameterType.DOUBLE_ARRAY, [1.0])  # type: ignore[arg-type]
    assert encode_state("n", "a", 1, 0, 0, listed, plain) is None  # not a core value (a list)
    assert decode_state(encode(_wire(StateArgs("n", "a", 1, 0, 0, listed, plain)))).value == (
        ParameterValue.from_python([1.0])  # the generated encoder takes it
    )
    with pytest.raises(struct.error):  # what the generated encoder does with it
        encode(wire.ParameterEvent(node_id="n", name="a", revision=2**63))


# ---- realistic parameter sets take the fast path ------------------------------------------------

_REPO = Path(__file__).resolve().parents[2]
_PLACES = (_REPO.parent / "shared" / "realworld", _REPO.parent.parent / "shared" / "realworld")
REALWORLD = next((p for p in _PLACES if p.is_dir()), _PLACES[0])
EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


def test_the_example_spec_takes_both_fast_paths() -> None:
    """The parameters of ``examples/robot_spec.yaml`` (descriptions, ranges, validators, arrays,
    read-only)."""
    kinds = set()
    for j, e in enumerate(load_spec(EXAMPLES / "robot_spec.yaml")):
        kinds.add(e.default.type)
        _check_encoding(StateArgs("robot_7", e.name, j, 1_700_000_000, j, e.default, e.descriptor))
    assert {ParameterType.STRING_ARRAY, ParameterType.DOUBLE_ARRAY, ParameterType.BOOL} <= kinds


@pytest.mark.skipif(not REALWORLD.is_dir(), reason=f"{REALWORLD} is absent (CI has it)")
def test_real_world_parameters_take_both_fast_paths() -> None:
    """Every parameter of two generate_parameter_library specs (their descriptors with
    validators, and defaults including NaN and infinities) and of robot_localization's
    ekf.yaml (15-element bool arrays, 225-element double matrices)."""
    args = [
        StateArgs("ctrl", e.name, 1, 0, 0, e.default, e.descriptor)
        for spec in ("joint_trajectory_controller_parameters.yaml", "diff_drive_controller_parameter.yaml")
        for e in load_spec(REALWORLD / spec)
    ]
    for name, value in load_ros_params(REALWORLD / "ekf.yaml", "ekf_filter_node").items():
        args.append(StateArgs("ekf_filter_node", name, 1, 0, 0, value, ParameterDescriptor(name, value.type)))
    assert len(args) > 100
    for a in args:
        _check_encoding(a)


@given(st.text(st.characters(exclude_categories=("Cs",)), max_size=60), st.text(max_size=60))
def test_an_instance_key_is_encoded_as_the_binding_does(node_id: str, name: str) -> None:
    sample = wire.ParameterEvent(node_id=node_id, name=name)
    expected = sample.serialize_key()
    expected = expected.ljust(-(-len(expected) // 4) * 4, b"\0")  # the binding pads keys to 4
    assert state.encode_key(node_id, name) == expected


def test_nodes_sharing_a_described_parameter_keep_their_own_incarnation_and_blame() -> None:
    """The decoded-descriptor cache is keyed on the descriptor's bytes: a fleet's nodes share
    the entry, and each sample still reads its own node's incarnation and its change's blame
    (the blame cache, keyed on the bytes after the incarnation, never mixes two authors up)."""
    v = ParameterValue.from_python(1.5)
    d = ParameterDescriptor("p", ParameterType.DOUBLE, "shared by every node")
    blames = [
        ("alice@robot-host", False, "cli"),
        ("alice@robot-host", True, "cli"),
        ("", False, ""),
        ("bob", False, "web"),
        ("alice@robot-host", False, "cli"),
    ]
    for incarnation in (1, 2**64 - 1, 0x1234_5678_9ABC_DEF0, 1):
        for who, verified, via in blames:
            a = StateArgs("n", "p", 3, 0, 0, v, d, incarnation, who, verified, via)
            data = encode_state(*a)
            assert data is not None
            expected = encode(_wire(a))
            assert data == expected + bytes(-len(expected) % 4)
            fast = _decode_fast(data)
            assert fast is not None
            assert (fast.incarnation, fast.descriptor) == (incarnation, d)
            assert (fast.who, fast.verified, fast.via) == (who, verified, via)
            assert canonical(fast) == canonical(decode_state_slowly(data))
    assert encode_state("n", "p", 3, 0, 0, v, d, 2**64) is None  # over uint64: the encoder decides
    assert encode_state("n", "p", 3, 0, 0, v, d, 1, "\ud800") is None  # no UTF-8 for it: the encoder decides


def test_departed_server_lives_leave_nothing_behind_in_the_decoder() -> None:
    """A long-lived monitor decodes the samples of servers that start and stop all along (the
    soak restarts a server of 10 nodes every 10 s): what the decoder keeps grows with the
    server processes and authors it met, not with nodes x lives x authors (kept with the
    incarnation, the tails of 200 lives of 10 nodes were 8,000 entries outliving their lives)."""
    lives, nodes, authors = 200, 10, ("soak-client0", "soak-client1", "alice@robot-host")
    v = ParameterValue.from_python(1.5)
    d = ParameterDescriptor("p", ParameterType.DOUBLE)
    before = sum(state.cache_sizes().values())
    for life in range(lives):
        pid, incarnation = 10_000 + life, 0x1234_5678_0000_0000 + life
        for n in range(nodes):
            node = f"soak_n{n:02d}"
            presence = wire.ParameterEvent(
                node_id=node,
                name="",
                kind=wire.EVENT_PRESENCE,
                revision=7,
                value=value_to_wire(NOT_SET),
                host="robot-host",
                pid=pid,
                parameter_count=3,
                incarnation=incarnation,
            )
            got = decode_state(encode(presence))
            assert (got.host, got.pid, got.incarnation) == ("robot-host", pid, incarnation)
            for who in authors:
                data = encode_state(node, "p", 7, 0, 0, v, d, incarnation, who, True, "api")
                assert data is not None
                got = decode_state(data)
                assert (got.host, got.pid, got.incarnation) == ("", 0, incarnation)
                assert (got.who, got.verified, got.via) == (who, True, "api")
    grown = sum(state.cache_sizes().values()) - before
    # a host, pid and count per server life; a few for the authors, the value, the descriptor
    assert grown <= lives + 20
