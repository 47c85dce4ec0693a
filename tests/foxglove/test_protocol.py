"""The protocol's messages and the access rules, pure: parsing, framing, the channel's schema, tokens."""

from __future__ import annotations

import json
import struct
from pathlib import Path

import jsonschema
import pytest

from paramdds.core.descriptors import FloatingPointRange, ParameterDescriptor
from paramdds.core.results import LastChange
from paramdds.core.values import ParameterType, ParameterValue
from paramdds.exits import UsageError
from paramdds.foxglove import protocol as p
from paramdds.foxglove.access import access_for, given_token, host_name, parse_tokens


def test_the_parameter_operations_parse() -> None:
    assert p.parse('{"op":"getParameters","parameterNames":[],"id":"a"}') == p.GetParameters((), "a")
    assert p.parse('{"op":"getParameters","parameterNames":["/arm.x"]}') == p.GetParameters(("/arm.x",), None)
    set_ = p.parse('{"op":"setParameters","parameters":[{"name":"/arm.x","value":1}],"id":"s"}')
    assert set_ == p.SetParameters(({"name": "/arm.x", "value": 1},), "s")
    assert p.parse('{"op":"subscribeParameterUpdates","parameterNames":["/a.b"]}') == p.SubscribeParameters(
        ("/a.b",)
    )
    assert p.parse('{"op":"unsubscribeParameterUpdates","parameterNames":[]}') == p.UnsubscribeParameters(())
    assert p.parse('{"op":"subscribe","subscriptions":[{"id":3,"channelId":1}]}') == p.Subscribe(((3, 1),))
    assert p.parse('{"op":"unsubscribe","subscriptionIds":[3]}') == p.Unsubscribe((3,))


@pytest.mark.parametrize(
    ("text", "why"),
    [
        ("{", "not JSON"),
        ("[]", "JSON object"),
        ('{"op":"dance"}', "unknown op"),
        ('{"op":"callService"}', "not offered"),
        ('{"op":"getParameters","parameterNames":[1]}', "list of strings"),
        ('{"op":"getParameters","parameterNames":[],"id":5}', "'id' is a string"),
        ('{"op":"setParameters","parameters":[{"value":1}]}', "list of {name"),
        ('{"op":"subscribe","subscriptions":[{"id":-1,"channelId":1}]}', "id, channelId"),
        ('{"op":"unsubscribe","subscriptionIds":["a"]}', "integers"),
    ],
)
def test_what_cannot_be_acted_on_says_why(text: str, why: str) -> None:
    with pytest.raises(p.ProtocolError, match=why):
        p.parse(text)


def test_server_messages() -> None:
    info = p.server_info("paramdds", "1", {})
    assert info["op"] == "serverInfo" and info["capabilities"] == ["parameters", "parametersSubscribe"]
    assert p.status(p.WARNING, "no", "s1") == {"op": "status", "level": 1, "message": "no", "id": "s1"}
    assert "id" not in p.parameter_values([])
    assert p.parameter_values([{"name": "/a.b"}], "g") == {
        "op": "parameterValues",
        "parameters": [{"name": "/a.b"}],
        "id": "g",
    }
    assert set(p.SUBPROTOCOLS) == {"foxglove.websocket.v1", "foxglove.sdk.v1"}


def test_message_data_is_the_binary_frame_of_the_protocol() -> None:
    frame = p.message_data(7, 123456789012345, b"{}")
    assert frame[0] == 0x01
    assert struct.unpack_from("<IQ", frame, 1) == (7, 123456789012345)
    assert frame[13:] == b"{}"


def test_the_channel_messages_follow_the_advertised_schema() -> None:
    (channel,) = p.advertise()["channels"]  # type: ignore[misc]
    assert channel["topic"] == "/paramdds/parameters" and channel["encoding"] == "json"
    schema = json.loads(channel["schema"])
    table = {
        "speed": (
            ParameterValue.of(ParameterType.DOUBLE, 1.5),
            ParameterDescriptor(
                "speed", ParameterType.DOUBLE, floating_point_range=FloatingPointRange(0.0, 5.0)
            ),
        ),
        "key": (ParameterValue.of(ParameterType.BYTE_ARRAY, b"\x01"), ParameterDescriptor("key")),
    }
    last = {"speed": LastChange("carol", False, "foxglove", 1_700_000_000_000_000_000, 3)}
    message = p.node_message("arm", True, 3, table, last)
    jsonschema.validate(json.loads(json.dumps(message)), schema)
    rows = message["parameters"]
    assert isinstance(rows, list)
    assert [r["name"] for r in rows] == ["/arm.key", "/arm.speed"]
    assert rows[1]["last_change"]["who"] == "carol" and rows[0]["last_change"] is None
    assert rows[1]["descriptor"]["floating_point_range"]["to_value"] == 5.0
    offline = p.node_message("arm", False, 3, table, last)
    jsonschema.validate(offline, schema)
    assert offline["parameters"] == []


def test_tokens_are_read_as_the_web_console_reads_them(tmp_path: Path) -> None:
    assert [(t.name, t.secret) for t in parse_tokens("# ops\ncarol 0123456789abcdef\n")] == [
        ("carol", "0123456789abcdef")
    ]
    with pytest.raises(ValueError, match="at least 16"):
        parse_tokens("short")
    assert access_for("127.0.0.1", None).tokens == ()
    with pytest.raises(UsageError, match="reachable from other machines"):
        access_for("0.0.0.0", None)
    f = tmp_path / "tokens"
    f.write_text("0123456789abcdef\n")
    remote = access_for("0.0.0.0", str(f))
    assert remote.token_to_connect and remote.hosts == ()
    local = access_for("127.0.0.1", str(f))
    assert not local.token_to_connect and "localhost" in local.hosts
    assert not local.may_set(None) and local.may_set(local.tokens[0])
    bad = tmp_path / "bad"
    bad.write_text("a b c\n")
    with pytest.raises(UsageError, match="--token-file"):
        access_for("127.0.0.1", str(bad))


def test_a_token_comes_in_the_url_or_as_a_bearer_header() -> None:
    assert given_token("/?token=abc", {}) == "abc"
    assert given_token("/", {"Authorization": "Bearer xyz"}) == "xyz"
    assert given_token("/", {"Authorization": "Basic xyz"}) == ""
    assert given_token("/", {}) == ""
    assert (host_name("[::1]:8765"), host_name("LocalHost:1"), host_name("robot")) == (
        "::1",
        "localhost",
        "robot",
    )
