"""Secure-mode fixtures: a Cyclone build with DDS Security, a keystore, two secure servers.

The PyPI cyclonedds wheel (the test environment's) has no DDS Security, so every
secure process runs in a second environment whose binding is built against Cyclone
C 11.0.1 with security: ``PARAMDDS_SECURE_VENV``, else ``build/secure/venv`` in the
checkout. ``.ci/run`` makes it (``paramdds keystore install``); by hand::

    python3 -m venv build/secure/venv && build/secure/venv/bin/pip install -e '.[secure,web]'
    build/secure/venv/bin/paramdds keystore install \\
        --source ../shared/vendor/cyclonedds-11.0.1.tar.gz --prefix build/secure/cyclone

Without it the tests that need it skip and say so; under ``CI=true`` they fail.
"""

from __future__ import annotations

import json
import os
import subprocess
import time
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import pytest

from ..conftest import TEST_URI, next_domain_id

ROOT = Path(__file__).resolve().parents[2]
PARAMS = """\
parameters:
  - {name: robot.max_velocity, type: double, value: 1.5}
  - {name: robot.name, type: string, value: my_robot}
  - {name: robot.mode, type: string, value: idle}
  - {name: robot.wheel_count, type: integer, value: 4}
"""
MISSING = (
    "no secure Cyclone environment (PARAMDDS_SECURE_VENV or build/secure/venv): make it with "
    "'paramdds keystore install' as tests/secure/conftest.py says"
)


def _secure_bin() -> Path | None:
    given = os.environ.get("PARAMDDS_SECURE_VENV", "").strip()
    venv = Path(given) if given else ROOT / "build" / "secure" / "venv"
    python = venv / "bin" / "python"
    if not python.is_file():
        return None
    check = "from paramdds.secure.identity import require_secure_library as r; r()"
    done = subprocess.run([str(python), "-c", check], capture_output=True, timeout=60, check=False)
    return venv / "bin" if done.returncode == 0 else None


def require_secure_bin() -> Path:
    """The secure environment's ``bin``; without one the test skips, or fails under CI=true."""
    found = _secure_bin()
    if found is None:
        if os.environ.get("CI", "").lower() == "true":
            pytest.fail(MISSING)
        pytest.skip(MISSING)
    return found


@pytest.fixture(scope="session")
def secure_bin() -> Path:
    return require_secure_bin()


@pytest.fixture(scope="session")
def keystore(tmp_path_factory: pytest.TempPathFactory) -> Path:
    from paramdds.secure.keystore import add_identity, init_keystore

    root = tmp_path_factory.mktemp("keystore")
    init_keystore(root)
    for name, role, nodes in (
        ("admin", "admin", ["*"]),
        ("srv1", "server", ["robot1"]),
        ("srv2", "server", ["robot2"]),
        ("op1", "operator", ["robot1*"]),
        ("srv34", "server", ["robot3", "robot4"]),
        ("op3", "operator", ["robot3"]),
        ("viewer", "viewer", ["*"]),
    ):
        add_identity(root, name, role, nodes)
    return root


@pytest.fixture(scope="session")
def foreign_keystore(tmp_path_factory: pytest.TempPathFactory) -> Path:
    from paramdds.secure.keystore import add_identity, init_keystore

    root = tmp_path_factory.mktemp("foreign")
    init_keystore(root)
    add_identity(root, "admin", "admin", ["*"])
    return root


@dataclass
class SecureSystem:
    """Two secure servers (robot1 as srv1, robot2 as srv2) on a domain of their own."""

    bin: Path
    keystore: Path
    domain: int
    params: Path

    def env(self, **extra: str) -> dict[str, str]:
        env = dict(os.environ)
        env.update(
            CYCLONEDDS_URI=TEST_URI,
            PARAMDDS_LOCALHOST="1",
            PARAMDDS_DOMAIN=str(self.domain),
            PYTHONUNBUFFERED="1",
        )
        env.pop("PARAMDDS_IDENTITY", None)
        env.update(extra)
        return env

    def identity(self, name: str, keystore: Path | None = None) -> str:
        return str((keystore or self.keystore) / "identities" / name)

    def run(
        self, identity: str | None, *args: str, timeout: float = 30, keystore: Path | None = None
    ) -> subprocess.CompletedProcess[str]:
        """``paramdds [--identity ID] ARGS`` in the secure environment."""
        cmd = [str(self.bin / "paramdds")]
        if identity is not None:
            cmd += ["--identity", self.identity(identity, keystore)]
        return subprocess.run(
            [*cmd, *args], capture_output=True, text=True, timeout=timeout, env=self.env(), check=False
        )

    def start(self, identity: str | None, *args: str, keystore: Path | None = None) -> subprocess.Popen[str]:
        cmd = [str(self.bin / "paramdds")]
        if identity is not None:
            cmd += ["--identity", self.identity(identity, keystore)]
        return subprocess.Popen(
            [*cmd, *args], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=self.env()
        )

    def nodes(self, identity: str | None, expected: set[str], tries: int = 3) -> dict[str, dict[str, object]]:
        """``paramdds nodes -o json`` until ``expected`` are listed (``tries`` runs at most).

        A one-shot ``nodes`` waits at most 2 s for the state to settle; on a loaded machine
        a secure handshake (certificates, key exchange) with one server can take longer.
        """
        listed: dict[str, dict[str, object]] = {}
        for _ in range(tries):
            done = self.run(identity, "nodes", "-o", "json")
            assert done.returncode == 0, done.stderr
            listed = {str(n["node"]): n for n in json.loads(done.stdout)}
            if expected <= set(listed):
                break
        return listed

    def value(self, node: str, name: str) -> object:
        """The value of one parameter, as a full-rights identity reads it."""
        done = self.run("admin", "get", node, name, "-o", "json")
        assert done.returncode == 0, done.stderr
        return json.loads(done.stdout)[name]


def stop(proc: subprocess.Popen[str], timeout: float = 10) -> tuple[str, str]:
    if proc.poll() is None:
        proc.terminate()
    try:
        return proc.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        proc.kill()
        return proc.communicate()


def wait_line(proc: subprocess.Popen[str], text: str, timeout: float = 30) -> None:
    """Read ``proc``'s stdout until a line containing ``text`` (the server's start line)."""
    assert proc.stdout is not None
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        line = proc.stdout.readline()
        if not line:
            _, err = stop(proc)
            raise AssertionError(f"process ended before {text!r}: {err}")
        if text in line:
            return
    raise AssertionError(f"no {text!r} within {timeout} s")


@pytest.fixture(scope="module")
def system(
    secure_bin: Path, keystore: Path, tmp_path_factory: pytest.TempPathFactory
) -> Iterator[SecureSystem]:
    params = tmp_path_factory.mktemp("params") / "params.yaml"
    params.write_text(PARAMS)
    sys_ = SecureSystem(secure_bin, keystore, next_domain_id(), params)
    servers = [
        sys_.start(ident, "server", "-n", node, "-p", str(params))
        for ident, node in (("srv1", "robot1"), ("srv2", "robot2"))
    ]
    try:
        for proc in servers:
            wait_line(proc, "[SERVER] Serving")
        yield sys_
    finally:
        errors = [stop(proc)[1] for proc in servers]
    for err in errors:  # nothing a test did (rogue samples, refused peers) broke a server's dispatch
        assert "Traceback" not in err, err
