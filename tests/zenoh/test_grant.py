"""The gateway's check at start that the router accepted its token (:mod:`paramdds.zenoh.grant`).

A real router (``paramdds zenoh --router``) on loopback TLS grants ``gw_a`` site ``a``
only. Sessions opened here with ``gw_a``'s certificate declare a gateway token of site
``a`` (accepted) or ``b`` (dropped by the access control), and the check asks the
router from a second session, as a gateway does.
"""

from __future__ import annotations

import os
import signal
import subprocess
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

pytest.importorskip("cryptography", reason="the secure extra (cryptography) is not installed")

from paramdds.errors import UnavailableError
from paramdds.zenoh import grant, keys
from paramdds.zenoh.config import TRY_TIMEOUT, TlsFiles, ZenohOptions, open_session

from ..conftest import next_domain_id
from ..reliability.conftest import PARAMDDS, Proc, make_dds_env
from .conftest import PARAMS, free_port

pytestmark = pytest.mark.timeout(120)


def _tls_args(d: Path) -> list[str]:
    return ["--tls-ca", str(d / "ca.pem"), "--tls-cert", str(d / "cert.pem"), "--tls-key", str(d / "key.pem")]


class Router:
    def __init__(self, tmp: Path, procs: list[Proc]) -> None:
        self.tmp, self.env = tmp, make_dds_env(next_domain_id())
        ks = tmp / "ks"
        subprocess.run([PARAMDDS, "keystore", "init", str(ks)], env=self.env, check=True, capture_output=True)
        for name, hosts in (("router", ["--host", "127.0.0.1"]), ("gw_a", [])):
            out = str(tmp / name)
            subprocess.run(
                [PARAMDDS, "zenoh", "--issue-cert", name, "--keystore", str(ks), "--out", out, *hosts],
                env=self.env,
                check=True,
                capture_output=True,
            )
        self.endpoint = f"tls/127.0.0.1:{free_port()}"
        argv = [PARAMDDS, "zenoh", "--router", "--listen", self.endpoint, *_tls_args(tmp / "router")]
        self.proc = Proc([*argv, "--grant", "gw_a=a"], self.env)
        procs.append(self.proc)
        self.proc.wait_for("[ZENOH] Router", 20)

    def options(self, cert: str) -> ZenohOptions:
        d = self.tmp / cert
        return ZenohOptions(
            connect=[self.endpoint], tls=TlsFiles(str(d / "ca.pem"), str(d / "cert.pem"), str(d / "key.pem"))
        )

    def session(self, cert: str = "gw_a") -> Any:
        return open_session(self.options(cert))


@pytest.fixture
def router(tmp_path: Path, procs: list[Proc]) -> Iterator[Router]:
    yield Router(tmp_path, procs)


def _token(session: Any, site: str) -> tuple[str, Any]:
    key = keys.gateway_key(site, f"{time.time_ns()}_{session.zid()}")
    return key, session.liveliness().declare_token(key)


def test_the_router_holds_a_granted_token_and_says_it_holds_none_of_a_refused_one(router: Router) -> None:
    session = router.session()
    try:
        granted, t1 = _token(session, "a")
        refused, t2 = _token(session, "b")
        started = time.monotonic()
        assert grant.check_token(session, router.session, granted) is grant.Grant.GRANTED
        assert time.monotonic() - started < 2.0
        started = time.monotonic()
        assert grant.check_token(session, router.session, refused) is grant.Grant.REFUSED
        took = time.monotonic() - started
        assert grant.REFUSED_AFTER <= took < grant.REFUSED_AFTER + 3.0, took
        # one ask of a probe on the same router: a full answer, without the refused token
        probe = router.session()
        try:
            assert grant.ask_router(probe, granted) is True
            assert grant.ask_router(probe, refused) is False
        finally:
            probe.close()
        t1.undeclare()
        t2.undeclare()
    finally:
        session.close()


@pytest.mark.slow  # waits out two probes that never answer, beside a stopped router
def test_a_probe_that_reaches_no_router_never_concludes_refused(router: Router) -> None:
    """The router gone (stopped, its sockets still open) or a probe that cannot connect: the
    check gives up, unknown; a gateway then goes on serving."""
    session = router.session()
    try:
        key, token = _token(session, "b")

        def no_router() -> Any:
            raise UnavailableError("no Zenoh router reachable")

        verdict = grant.check_token(session, no_router, key, give_up_after=2.0)
        assert verdict is grant.Grant.UNKNOWN
        probe = router.session()  # connected, then its router stops answering
        router.proc.popen.send_signal(signal.SIGSTOP)  # its sockets stay open: no link is lost
        try:
            started = time.monotonic()
            verdict = grant.check_token(session, lambda: probe, key, refused_after=0.5, give_up_after=3.0)
            took = time.monotonic() - started
        finally:
            router.proc.popen.send_signal(signal.SIGCONT)
        assert verdict is grant.Grant.UNKNOWN
        assert took >= 3.0, took
        token.undeclare()
    finally:
        session.close()


def test_only_a_gateway_dialling_a_router_as_a_client_is_checked() -> None:
    assert grant.probe_opener(ZenohOptions(mode="peer", listen=["tcp/127.0.0.1:7447"])) is None
    assert grant.probe_opener(ZenohOptions(mode="peer", connect=["tcp/127.0.0.1:7447"])) is None
    opener = grant.probe_opener(ZenohOptions(connect=["tcp/127.0.0.1:1"], open_timeout=60.0))
    assert opener is not None
    started = time.monotonic()
    with pytest.raises(UnavailableError):
        opener()  # nobody there: each try of the probe is bounded, not the gateway's whole wait
    assert time.monotonic() - started < TRY_TIMEOUT + 1.0


@pytest.mark.slow
def test_a_gateway_not_granted_its_site_stops_at_start_and_a_granted_one_serves(
    router: Router, procs: list[Proc]
) -> None:
    env = make_dds_env(next_domain_id())
    server = Proc([PARAMDDS, "server", "-p", PARAMS, "-n", "robot1"], env)
    procs.append(server)
    server.wait_for("[SERVER] Serving node", 20)
    certs = _tls_args(router.tmp / "gw_a")
    refused = Proc([PARAMDDS, "zenoh", "--site", "b", "--connect", router.endpoint, *certs], env)
    procs.append(refused)
    assert refused.popen.wait(30) == 1, refused.stderr_text()
    assert "certificate is not granted site 'b'" in refused.stderr_text()
    assert not any("[ZENOH] Gateway for site" in line for _, line in refused.lines)
    granted = Proc([PARAMDDS, "zenoh", "--site", "a", "--connect", router.endpoint, *certs], env)
    procs.append(granted)
    granted.wait_for("[ZENOH] Gateway for site a", 20)
    assert "not granted" not in granted.stderr_text()


STARTS = os.environ.get("PARAMDDS_MEASURE_GRANT", "")  # "30,10": healthy starts, refused starts


@pytest.mark.skipif(not STARTS, reason="a measurement, not a check: PARAMDDS_MEASURE_GRANT=30,10")
@pytest.mark.timeout(3600)
def test_measure_gateway_starts_granted_and_refused(router: Router, procs: list[Proc]) -> None:
    """Gateways started again and again with ``gw_a``'s certificate: for site ``a`` (granted)
    each must serve, for site ``b`` (not granted) each must stop, exit 1; the times printed."""
    healthy, refused = (int(n) for n in STARTS.split(","))
    env = make_dds_env(next_domain_id())
    server = Proc([PARAMDDS, "server", "-p", PARAMS, "-n", "robot1"], env)
    procs.append(server)
    server.wait_for("[SERVER] Serving node", 20)
    certs = _tls_args(router.tmp / "gw_a")
    served, stopped, wrong = [], [], []
    for k in range(healthy + refused):
        site = "a" if k < healthy else "b"
        started = time.monotonic()
        gw = Proc([PARAMDDS, "zenoh", "--site", site, "--connect", router.endpoint, *certs], env)
        if site == "a":
            gw.wait_for("[ZENOH] Gateway for site a", 60)
            served.append(time.monotonic() - started)
            gw.stop()
            if "not granted" in gw.stderr_text() or "could not ask" in gw.stderr_text():
                wrong.append(f"start {k}: {gw.stderr_text()}")
        else:
            code = gw.popen.wait(60)
            stopped.append(time.monotonic() - started)
            gw.stop()
            if code != 1 or "certificate is not granted site 'b'" not in gw.stderr_text():
                wrong.append(f"start {k}: exit {code}: {gw.stderr_text()}")
    print(
        f"{len(served)} granted starts served in {min(served):.2f}-{max(served):.2f} s; "
        f"{len(stopped)} refused starts stopped in {min(stopped):.2f}-{max(stopped):.2f} s; wrong: {wrong}"
    )
    assert not wrong, wrong
