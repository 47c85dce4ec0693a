"""Pure parts of a gateway's start: the pauses between tries, and endpoint checks."""

from __future__ import annotations

import itertools

import pytest

from paramdds.errors import ParamddsError
from paramdds.zenoh.config import RETRY_FIRST, RETRY_MAX, check_endpoint, retry_delays


def test_the_pause_between_tries_doubles_up_to_a_ceiling_and_never_ends() -> None:
    pauses = list(itertools.islice(retry_delays(), 12))
    assert pauses[:6] == [0.5, 1.0, 2.0, 4.0, 8.0, 10.0]
    assert pauses[6:] == [RETRY_MAX] * 6
    assert pauses[0] == RETRY_FIRST


def test_a_port_out_of_range_is_named_as_such() -> None:
    with pytest.raises(ParamddsError, match=r"port 99999 is not within 1-65535"):
        check_endpoint("tcp/127.0.0.1:99999")
    with pytest.raises(ParamddsError, match="needs HOST:PORT"):
        check_endpoint("tcp/127.0.0.1")
    assert check_endpoint("tcp/127.0.0.1:7447") == "tcp/127.0.0.1:7447"
