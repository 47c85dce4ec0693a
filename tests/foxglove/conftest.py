"""Node.js test clients for the Foxglove tests: npm packages installed into the test folder.

``tests/foxglove/node`` holds a ``package.json`` and its ``package-lock.json`` (pinned
``@foxglove/ws-protocol``, ``ws``, ``@mcap/core``, ``@mcap/support``) and the scripts that
use them. :func:`require_node_packages` runs ``npm ci`` there once (``node_modules`` is
git-ignored) and again only when the lock file changes: a stamp in ``node_modules`` holds the
lock file's hash. A file lock keeps two pytest processes from installing at once.

Without ``node``, ``npm`` or the registry the tests skip with the reason; under ``CI=true``
they fail. Every script prints JSON lines and ends with a ``done`` event, or ``error`` or
``timeout`` (``node/lines.js``; the FoxgloveClient scenarios build on ``node/client.js``).
:func:`run_node` runs one script to its end; :func:`start_node` starts one as a
:class:`~tests.reliability.conftest.Proc` whose JSON lines a test reads as they come. Tests
elsewhere (``tests/record``) call :func:`require_node_packages` before them.
"""

from __future__ import annotations

import fcntl
import hashlib
import json
import os
import shutil
import subprocess
from collections.abc import Sequence
from pathlib import Path
from typing import Any, NoReturn

import pytest

from ..reliability.conftest import Proc

NODE_DIR = Path(__file__).with_name("node")
LOCK_FILE = NODE_DIR / "package-lock.json"
STAMP = NODE_DIR / "node_modules" / ".paramdds-lock-sha256"
NODE_MAJOR_MIN = 18  # @mcap/core and ws need a fetch-era Node; Debian 12 ships 18
INSTALL_TIMEOUT = 300.0

_installed: Path | None = None


def in_ci() -> bool:
    return os.environ.get("CI", "").strip().lower() in {"1", "true", "yes"}


def _unavailable(reason: str) -> NoReturn:
    if in_ci():
        pytest.fail(f"CI: {reason}")
    pytest.skip(reason)


def _node_major(node: str) -> int | None:
    try:
        out = subprocess.run(
            [node, "--version"], capture_output=True, text=True, timeout=30, check=True
        ).stdout
        return int(out.strip().lstrip("v").split(".")[0])
    except (OSError, subprocess.SubprocessError, ValueError):
        return None


def _npm_error(stderr: str) -> str:
    """npm's first few error lines, without its stack and its log file's name."""
    lines = [
        line.removeprefix("npm error").strip() for line in stderr.splitlines() if line.startswith("npm error")
    ]
    kept = [line for line in lines if line and not line.startswith(("at ", "A complete log"))]
    return "; ".join(kept[:4]) or stderr.strip()[-300:] or "no output"


def _install(npm: str, digest: str) -> None:
    """``npm ci`` from the lock file into NODE_DIR/node_modules, then the stamp."""
    try:
        done = subprocess.run(
            [npm, "ci", "--no-audit", "--no-fund", "--ignore-scripts", "--loglevel=error"],
            cwd=NODE_DIR,
            capture_output=True,
            text=True,
            timeout=INSTALL_TIMEOUT,
        )
    except subprocess.TimeoutExpired:
        _unavailable(
            f"npm ci in {NODE_DIR} took over {INSTALL_TIMEOUT:.0f} s (is the npm registry reachable?)"
        )
    if done.returncode != 0:
        _unavailable(
            f"npm ci in {NODE_DIR} failed (is the npm registry reachable?): {_npm_error(done.stderr)}"
        )
    STAMP.write_text(digest + "\n")


def require_node_packages() -> Path:
    """The folder of the Node scripts with their packages installed (skip, or fail in CI, if not)."""
    global _installed
    if _installed is not None:
        return _installed
    node, npm = shutil.which("node"), shutil.which("npm")
    if node is None or npm is None:
        _unavailable("the Foxglove client tests need Node.js and npm (Debian: apt-get install nodejs npm)")
    major = _node_major(node)
    if major is None or major < NODE_MAJOR_MIN:
        _unavailable(f"the Foxglove client tests need Node.js >= {NODE_MAJOR_MIN}; {node} is {major}")
    digest = hashlib.sha256(LOCK_FILE.read_bytes()).hexdigest()
    with open(NODE_DIR / ".install.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if not STAMP.is_file() or STAMP.read_text().strip() != digest:
            _install(npm, digest)
    _installed = NODE_DIR
    return NODE_DIR


@pytest.fixture(scope="session")
def node_dir() -> Path:
    """``tests/foxglove/node`` with its npm packages installed."""
    return require_node_packages()


def node_argv(script: str, *args: str) -> list[str]:
    """The command line of one of the Node scripts (``node_dir`` must have been asked for)."""
    node = shutil.which("node")
    assert node is not None
    return [node, str(NODE_DIR / script), *args]


def parse_lines(lines: Sequence[str]) -> list[dict[str, Any]]:
    """The JSON lines a script printed, as dicts."""
    return [json.loads(line) for line in lines if line.strip()]


def run_node(script: str, *args: str, timeout: float = 20.0) -> list[dict[str, Any]]:
    """Run a script to its end; its events, the last of them ``done`` (else the test fails)."""
    env = {**os.environ, "FOXGLOVE_TEST_TIMEOUT": str(timeout)}
    done = subprocess.run(
        node_argv(script, *args), capture_output=True, text=True, env=env, timeout=timeout + 10, check=False
    )
    events = parse_lines(done.stdout.splitlines())
    assert done.returncode == 0 and events and events[-1]["event"] == "done", (
        f"node {script} {' '.join(args)} exited {done.returncode}: {events!r}; stderr {done.stderr!r}"
    )
    return events


def start_node(script: str, *args: str, timeout: float = 20.0) -> Proc:
    """Start a script; read its lines with ``Proc.wait_for`` (and parse them with json.loads)."""
    return Proc(node_argv(script, *args), {**os.environ, "FOXGLOVE_TEST_TIMEOUT": str(timeout)})
