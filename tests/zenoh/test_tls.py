"""Mutual TLS with certificates from a ``paramdds keystore`` CA, and access control by certificate name.

A router (a ``paramdds zenoh --router`` process) on loopback TLS grants ``gw_a`` site
``a``, ``gw_b`` site ``a`` too (so gateway b, which serves site ``b``, stops at start),
``gw_c`` site ``c`` and ``operator`` site ``a`` (site ``c`` is up, but not granted to
it); a client without a certificate does not connect.
"""

from __future__ import annotations

import json
import subprocess
from pathlib import Path

import pytest

pytest.importorskip("cryptography", reason="the secure extra (cryptography) is not installed")

from paramdds.errors import NotPermittedError, UnavailableError
from paramdds.zenoh.client import RemoteParameterClient
from paramdds.zenoh.config import TlsFiles, ZenohOptions, open_session
from paramdds.zenoh.monitor import RemoteParameterMonitor

from ..conftest import next_domain_id
from ..reliability.conftest import PARAMDDS, Proc, make_dds_env
from .conftest import PARAMS, free_port, holds_online, wait_for

pytestmark = pytest.mark.timeout(90)


def _tls_args(d: Path) -> list[str]:
    return ["--tls-ca", str(d / "ca.pem"), "--tls-cert", str(d / "cert.pem"), "--tls-key", str(d / "key.pem")]


@pytest.mark.slow
def test_mutual_tls_and_access_by_certificate_name(tmp_path: Path, procs: list[Proc]) -> None:
    env = make_dds_env(next_domain_id())
    ks = tmp_path / "ks"
    assert (
        subprocess.run([PARAMDDS, "keystore", "init", str(ks)], env=env, capture_output=True).returncode == 0
    )
    names: list[tuple[str, list[str]]] = [("router", ["127.0.0.1"])]
    names += [(name, []) for name in ("gw_a", "gw_b", "gw_c", "operator")]
    for name, hosts in names:
        argv = [PARAMDDS, "zenoh", "--issue-cert", name, "--keystore", str(ks), "--out", str(tmp_path / name)]
        for h in hosts:
            argv += ["--host", h]
        done = subprocess.run(argv, env=env, capture_output=True, text=True)
        assert done.returncode == 0, done.stderr
    assert (tmp_path / "operator" / "key.pem").stat().st_mode & 0o077 == 0
    endpoint = f"tls/127.0.0.1:{free_port()}"
    router = Proc(
        [
            PARAMDDS, "zenoh", "--router", "--listen", endpoint, *_tls_args(tmp_path / "router"),
            "--grant", "gw_a=a", "--grant", "gw_b=a", "--grant", "gw_c=c", "--grant", "operator=a",
        ],
        env,
    )  # fmt: skip
    procs.append(router)
    router.wait_for("[ZENOH] Router", 20)
    for site, cert in (("a", "gw_a"), ("b", "gw_b"), ("c", "gw_c")):
        domain_env = make_dds_env(next_domain_id())
        server = Proc([PARAMDDS, "server", "-p", PARAMS, "-n", "robot1"], domain_env)
        procs.append(server)
        server.wait_for("[SERVER] Serving node", 20)
        gw = Proc(
            [PARAMDDS, "zenoh", "--site", site, "--connect", endpoint, *_tls_args(tmp_path / cert)],
            domain_env,
        )
        procs.append(gw)
        if site != "b":
            gw.wait_for("[ZENOH] Gateway for site", 20)
        else:  # gw_b is not granted site b: it stops at start, saying why (a refusal: exit 1)
            assert gw.popen.wait(30) == 1, gw.stderr_text()
            assert "certificate is not granted site 'b'" in gw.stderr_text()
            assert not any("[ZENOH] Gateway for site" in line for _, line in gw.lines)

    op = tmp_path / "operator"
    session = open_session(
        ZenohOptions(
            connect=[endpoint], tls=TlsFiles(str(op / "ca.pem"), str(op / "cert.pem"), str(op / "key.pem"))
        )
    )
    try:
        monitor = RemoteParameterMonitor(session, sites=["a", "b"])
        assert holds_online(monitor, ["a/robot1"], 5.0)
        client = RemoteParameterClient(session, timeout=3.0)
        assert client.set("a/robot1", {"robot.max_velocity": 2.0}).successful
        # site b's gateway stopped (not granted its own keys): nothing of b reaches anyone
        assert not wait_for(lambda: "b/robot1" in monitor.snapshot(), 1.5)
        with pytest.raises(UnavailableError):
            client.get("b/robot1", ["robot.max_velocity"], timeout=2.0)
        # site c is up but not granted to this operator: a refusal by name, not a network fault
        with pytest.raises(NotPermittedError, match="site 'c' is not granted to this client"):
            client.get("c/robot1", ["robot.max_velocity"], timeout=2.0)
        monitor.close()
    finally:
        session.close()

    # the CLI as that operator: its certificate, and the sites it is granted
    cli = subprocess.run(
        [PARAMDDS, "--zenoh", endpoint, "nodes", "-o", "json"],
        env={**env, "PARAMDDS_ZENOH_TLS": str(op), "PARAMDDS_ZENOH_SITES": "a,b"},
        capture_output=True,
        text=True,
        timeout=30,
    )
    # site b, named but unreachable (its gateway is not granted it), is said lacking: exit 3
    assert cli.returncode == 3, cli.stderr
    assert [n["node"] for n in json.loads(cli.stdout)] == ["a/robot1", "b/*"]
    assert "lacks site 'b'" in cli.stderr

    refused = subprocess.run(
        [PARAMDDS, "--zenoh", endpoint, "get", "c/robot1", "robot.max_velocity"],
        env={**env, "PARAMDDS_ZENOH_TLS": str(op)},
        capture_output=True,
        text=True,
        timeout=30,
    )
    assert refused.returncode == 1 and "not granted" in refused.stderr, refused
    # naming no site, the operator is shown every site: c as not granted (a refusal: exit 1)
    unnamed = subprocess.run(
        [PARAMDDS, "--zenoh", endpoint, "nodes", "-o", "json"],
        env={**env, "PARAMDDS_ZENOH_TLS": str(op)},
        capture_output=True,
        text=True,
        timeout=30,
    )
    assert unnamed.returncode == 1, unnamed.stderr
    rows = {r["node"]: r["status"] for r in json.loads(unnamed.stdout)}
    assert rows == {"a/robot1": None, "c/*": "not granted"}, rows
    assert "site 'c' is not granted to this client" in unnamed.stderr
    # and a watch of every site follows the sites granted (it used to print only `synced`)
    watch = Proc([PARAMDDS, "--zenoh", endpoint, "watch"], {**env, "PARAMDDS_ZENOH_TLS": str(op)})
    procs.append(watch)
    watch.wait_for("added    a/robot1 robot.max_velocity", 20)
    watch.wait_for("synced", 10)
    session = open_session(
        ZenohOptions(
            connect=[endpoint], tls=TlsFiles(str(op / "ca.pem"), str(op / "cert.pem"), str(op / "key.pem"))
        )
    )
    try:
        client = RemoteParameterClient(session, timeout=3.0)
        assert client.set("a/robot1", {"robot.max_velocity": 2.5}).successful
    finally:
        session.close()
    watch.wait_for("modified a/robot1 robot.max_velocity = double 2.5", 10)

    # no certificate: no session at all, within the bounded wait
    with pytest.raises(UnavailableError, match="no Zenoh router reachable"):
        open_session(ZenohOptions(connect=[endpoint], open_timeout=1.5))
    # a valid certificate of a name granted nothing: connected, but it reaches no site
    nobody = tmp_path / "nobody"
    subprocess.run(
        [PARAMDDS, "zenoh", "--issue-cert", "nobody", "--keystore", str(ks), "--out", str(nobody)],
        env=env,
        check=True,
        capture_output=True,
    )
    session = open_session(
        ZenohOptions(
            connect=[endpoint],
            tls=TlsFiles(str(nobody / "ca.pem"), str(nobody / "cert.pem"), str(nobody / "key.pem")),
        )
    )
    try:
        with pytest.raises(UnavailableError):
            RemoteParameterClient(session, timeout=2.0).get("a/robot1", ["robot.max_velocity"])
    finally:
        session.close()
    # ... and its `nodes` says so at once, never an empty fleet with exit 0
    empty = subprocess.run(
        [PARAMDDS, "--zenoh", endpoint, "nodes"],
        env={**env, "PARAMDDS_ZENOH_TLS": str(nobody)},
        capture_output=True,
        text=True,
        timeout=30,
    )
    assert empty.returncode == 3, empty
    assert "this client is granted no site" in empty.stderr

    # the web console as that operator lists site c as a site lacking, not granted
    port = free_port()
    web = Proc(
        [PARAMDDS, "--zenoh", endpoint, "web", "--bind", f"127.0.0.1:{port}"],
        {**env, "PARAMDDS_ZENOH_TLS": str(op)},
    )
    procs.append(web)
    web.wait_for("[WEB] Console on", 30)

    def listed() -> tuple[list[str], list[tuple[str, str]]]:
        import urllib.request

        with urllib.request.urlopen(f"http://127.0.0.1:{port}/api/nodes", timeout=5) as r:
            body = json.loads(r.read())
        return [n["node"] for n in body["nodes"]], [(m["site"], m["status"]) for m in body["missing"]]

    assert wait_for(lambda: listed() == (["a/robot1"], [("c", "not granted")]), 10.0), listed()
