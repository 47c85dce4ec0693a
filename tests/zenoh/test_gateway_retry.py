"""Pure parts of a gateway's start: the pauses between tries, endpoint checks, a missing extra."""

from __future__ import annotations

import argparse
import itertools
import sys
from pathlib import Path

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


def test_a_missing_secure_extra_is_a_usage_error_naming_it(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path
) -> None:
    import importlib.util

    from paramdds.cli.verbs import keystore, zenoh
    from paramdds.exits import UsageError

    real = importlib.util.find_spec
    monkeypatch.setattr(
        importlib.util, "find_spec", lambda name, *a: None if name == "cryptography" else real(name, *a)
    )
    monkeypatch.setitem(sys.modules, "cryptography", None)  # as if not installed: importing fails
    extra = r"cryptography not installed\): pip install -e '\.\[secure\]' in the paramdds checkout"
    with pytest.raises(UsageError, match=r"'paramdds keystore' needs the secure extra \(" + extra):
        keystore.run(argparse.Namespace(action="init", keystore=str(tmp_path / "ks")))
    assert not (tmp_path / "ks").exists()  # nothing half made
    ks, out = str(tmp_path / "ks"), str(tmp_path / "o")
    args = argparse.Namespace(issue_cert="gw", keystore=ks, out=out, host=[])
    with pytest.raises(UsageError, match=r"--issue-cert' needs the secure extra \(" + extra):
        zenoh.run(args)


def test_each_failed_try_is_logged_and_followed_by_the_next_pause(
    monkeypatch: pytest.MonkeyPatch, caplog: pytest.LogCaptureFixture
) -> None:
    from paramdds.errors import UnavailableError
    from paramdds.zenoh import config

    now = [0.0]
    results: list[object] = [UnavailableError("down"), UnavailableError("down"), "session"]

    def fake_open(options: config.ZenohOptions) -> object:
        assert 0 < options.open_timeout <= config.TRY_TIMEOUT  # one try, bounded by what is left
        now[0] += options.open_timeout  # a failed try waits its whole timeout
        result = results.pop(0)
        if isinstance(result, Exception):
            raise result
        return result

    pauses: list[float] = []

    def fake_sleep(seconds: float) -> None:
        pauses.append(seconds)
        now[0] += seconds

    monkeypatch.setattr(config, "open_session", fake_open)
    opts = config.ZenohOptions(connect=["tcp/10.0.0.1:7447"])
    with caplog.at_level("WARNING", logger="paramdds.zenoh.config"):
        got = config.open_session_waiting(opts, None, sleep=fake_sleep, clock=lambda: now[0])
    assert got == "session" and pauses == [0.5, 1.0]
    lines = [r.getMessage() for r in caplog.records]
    assert lines == [
        "no Zenoh router reachable at tcp/10.0.0.1:7447 (try 1, 2.0 s since start): trying again in 0.5 s",
        "no Zenoh router reachable at tcp/10.0.0.1:7447 (try 2, 4.5 s since start): trying again in 1.0 s",
        "reached the Zenoh router at tcp/10.0.0.1:7447 at try 3",
    ]

    # bounded: the last pause is cut to what is left, then one try more, then exit 3's error
    now[0], pauses[:] = 0.0, []
    results[:] = [UnavailableError("down")] * 5
    with pytest.raises(UnavailableError, match=r"within 3 s \(2 tries\)"):
        config.open_session_waiting(opts, 3.0, sleep=fake_sleep, clock=lambda: now[0])
    assert pauses == [0.5]
