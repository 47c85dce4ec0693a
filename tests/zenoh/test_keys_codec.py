"""The wire contract without Zenoh or DDS: key expressions and JSON payloads."""

from __future__ import annotations

import json
import math

import pytest

from paramdds.core.descriptors import FloatingPointRange, IntegerRange, ParameterDescriptor, Validator
from paramdds.core.revision import Revision
from paramdds.core.values import Parameter, ParameterType, ParameterValue
from paramdds.errors import ConflictError, ErrorCode, FileFormatError, InvalidNameError, TooLargeError
from paramdds.zenoh import codec, keys


def test_node_ids_with_slashes_become_one_key_chunk_and_back() -> None:
    key = keys.node_key("warehouse_1", "/fleet/robot1", "state")
    assert key == "paramdds/warehouse_1/node/fleet%robot1/state"
    assert keys.parse_node_key(key) == ("warehouse_1", "fleet/robot1", "state")
    assert keys.split_remote("warehouse_1/fleet/robot1") == ("warehouse_1", "fleet/robot1")


@pytest.mark.parametrize("site", ["", "a/b", "a*", "a$b", "ware-house", "x" * 65, "é"])
def test_a_site_that_is_not_one_plain_key_chunk_is_refused(site: str) -> None:
    with pytest.raises(InvalidNameError, match="invalid site name"):
        keys.check_site(site)


@pytest.mark.parametrize("name", ["robot1", "", "site/", "bad-site/robot1", "s/ro*bot"])
def test_remote_names_need_a_site_and_a_node(name: str) -> None:
    with pytest.raises(InvalidNameError):
        keys.split_remote(name)


def test_a_key_that_is_not_a_node_key_is_refused() -> None:
    for key in ("paramdds/s1/gateway/abc", "paramdds/s1/node/a%%b/get", "other/s1/node/n/get"):
        with pytest.raises(InvalidNameError):
            keys.parse_node_key(key)


def test_gateway_tokens_name_the_gateway_and_when_the_active_one_took_the_role() -> None:
    assert keys.parse_gateway_key(keys.gateway_key("s1", "17_ab")) == ("17_ab", None)
    assert keys.active_key("s1", "17_ab", 42) == "paramdds/s1/gateway/17_ab/active/42"
    assert keys.parse_gateway_key(keys.active_key("s1", "17_ab", 42)) == ("17_ab", 42)
    for key in ("paramdds/s1/gateway/17_ab/active/x", "paramdds/s1/gateway/a/b", "paramdds/s1/node/n/alive"):
        with pytest.raises(InvalidNameError):
            keys.parse_gateway_key(key)


def test_every_value_type_round_trips_through_json_exactly() -> None:
    values = [
        ParameterValue.of(ParameterType.BOOL, True),
        ParameterValue.of(ParameterType.INTEGER, -(2**63)),
        ParameterValue.of(ParameterType.DOUBLE, -0.0),
        ParameterValue.of(ParameterType.DOUBLE, math.inf),
        ParameterValue.of(ParameterType.DOUBLE, math.nan),
        ParameterValue.of(ParameterType.STRING, "nan"),
        ParameterValue.of(ParameterType.BYTE_ARRAY, b"\x00\xff"),
        ParameterValue.of(ParameterType.BOOL_ARRAY, [True, False]),
        ParameterValue.of(ParameterType.INTEGER_ARRAY, [1, 2]),
        ParameterValue.of(ParameterType.DOUBLE_ARRAY, [1.5, -math.inf]),
        ParameterValue.of(ParameterType.STRING_ARRAY, []),
        ParameterValue.of(ParameterType.NOT_SET, None),
    ]
    for v in values:
        back = codec.value_in(json.loads(codec.dumps(codec.value_out(v))))
        assert back.same_as(v), (v, back)
    # a writer in another language may drop a double's ".0"
    assert codec.value_in({"type": "double", "value": 2}).same_as(
        ParameterValue.of(ParameterType.DOUBLE, 2.0)
    )


def test_a_node_state_with_descriptors_round_trips() -> None:
    d = ParameterDescriptor(
        "a",
        ParameterType.DOUBLE,
        description="m/s",
        read_only=True,
        floating_point_range=FloatingPointRange(0.0, 5.0, 0.5),
        validators=(Validator("bounds", (ParameterValue.of(ParameterType.DOUBLE, 0.0),) * 2),),
    )
    i = ParameterDescriptor("b", ParameterType.INTEGER, integer_range=IntegerRange(1, 9, 2))
    msg = codec.NodeStateMsg(
        "s1",
        "ns/r1",
        "ab12",
        7,
        True,
        "host",
        42,
        3,
        2**64 - 1,
        2,
        "ros2",
        {
            "a": (ParameterValue.of(ParameterType.DOUBLE, 1.0), d),
            "b": (ParameterValue.of(ParameterType.INTEGER, 3), i),
        },
    )
    assert codec.NodeStateMsg.decode(msg.encode()) == msg
    assert json.loads(msg.encode())["incarnation"] == "ffffffffffffffff"


def test_replies_keep_codes_and_errors_map_to_the_tree() -> None:
    obj = json.loads(codec.error_reply(ConflictError("lost")))
    assert obj == {"ok": False, "code": "CONFLICT", "message": "lost"}
    with pytest.raises(ConflictError):
        codec.check_reply(obj)
    unknown = {"ok": False, "code": "FROM_THE_FUTURE", "message": "x"}
    with pytest.raises(Exception) as info:
        codec.check_reply(unknown)
    assert getattr(info.value, "code", None) is ErrorCode.UNKNOWN


def test_a_set_request_carries_a_revision_as_text() -> None:
    body = json.loads(
        codec.set_request(
            [Parameter("x", ParameterValue.of(ParameterType.INTEGER, 1))], True, Revision(10, 3), 2.0
        )
    )
    assert body["if_revision"] == "000000000000000a:3"
    assert codec.parse_if_revision(body["if_revision"]) == Revision(10, 3)
    assert codec.parse_parameters(body["parameters"])[0].value.value == 1


def test_malformed_or_huge_payloads_are_clear_errors() -> None:
    with pytest.raises(FileFormatError, match="not JSON"):
        codec.loads(b"{nope", "a reply")
    with pytest.raises(FileFormatError, match="not a JSON object"):
        codec.loads(b"[1]", "a reply")
    with pytest.raises(TooLargeError):
        codec.loads(b" " * (codec.MAX_PAYLOAD + 1), "a reply")
    with pytest.raises(FileFormatError, match="malformed node state"):
        codec.NodeStateMsg.decode(b'{"site": "s"}')
