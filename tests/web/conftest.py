"""Fixtures of the web console tests: one domain, two nodes and one console per module."""

from __future__ import annotations

import os
import shutil
import tempfile
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import httpx
import pytest
from playwright.sync_api import expect

from tests.support.browser import CHROMIUM_FLAGS

from ..cli._support import Proc, next_domain, start_server
from ._support import CONSOLE_PARAMS, Console


@pytest.fixture(scope="module")
def domain() -> int:
    return next_domain()


@pytest.fixture(scope="module")
def servers(domain: int) -> Iterator[Proc]:
    """``arm`` and ``base``, each holding examples/console_params.yaml."""
    proc = start_server(domain, "-n", "arm", "-n", "base", "-p", str(CONSOLE_PARAMS))
    yield proc
    if proc.popen.poll() is None:
        proc.stop()


@pytest.fixture(scope="module")
def console(domain: int, servers: Proc) -> Iterator[Console]:
    c = Console(domain)
    try:
        wait_for_nodes(c.url, {"arm", "base"})
        yield c
    finally:
        c.stop()


def wait_for_nodes(url: str, nodes: set[str], params: int = 9, timeout: float = 15.0) -> None:
    """Until the console lists every node of ``nodes`` online with all its parameters."""
    import time

    deadline = time.monotonic() + timeout
    seen: dict[str, object] = {}
    while time.monotonic() < deadline:
        body = httpx.get(url + "api/nodes", timeout=5).json()
        seen = {n["node"]: n for n in body["nodes"]}
        if all(n in seen and seen[n]["online"] and seen[n]["parameters"] == params for n in nodes):  # type: ignore[index]
            return
        time.sleep(0.1)
    raise AssertionError(f"the console did not list {sorted(nodes)} in {timeout} s: {seen}")


# -- the browser ---------------------------------------------------------------------------------

expect.set_options(timeout=15_000)  # a loaded 2-core CI machine; a passing check returns at once



def chromium_path() -> str:
    """Debian's chromium; skipped locally when absent, a failure in CI (CI=true)."""
    path = os.environ.get("PARAMDDS_CHROMIUM") or shutil.which("chromium") or "/usr/bin/chromium"
    if not Path(path).exists():
        reason = f"no Chromium at {path} (apt-get install chromium; .ci/run does)"
        if os.environ.get("CI", "").lower() == "true":
            pytest.fail(reason)
        pytest.skip(reason)
    return path


@pytest.fixture(scope="module")
def browser() -> Iterator[Any]:
    from playwright.sync_api import sync_playwright

    executable = chromium_path()
    profile = tempfile.mkdtemp(prefix="paramdds-chromium-")
    with sync_playwright() as p:
        context = p.chromium.launch_persistent_context(
            profile, executable_path=executable, args=CHROMIUM_FLAGS, viewport={"width": 1280, "height": 800}
        )
        try:
            yield context
        finally:
            context.close()
            shutil.rmtree(profile, ignore_errors=True)


@pytest.fixture
def page(browser: Any, request: pytest.FixtureRequest, tmp_path: Path) -> Iterator[Any]:
    """A fresh tab; on failure its screenshot is saved as ``failure.png`` in the test's tmp_path."""
    tab = browser.new_page()
    errors: list[str] = []
    tab.on("pageerror", lambda exc: errors.append(str(exc)))
    request.node.paramdds_page = (tab, tmp_path)
    yield tab
    tab.close()
    assert not errors, f"JavaScript errors on the page: {errors}"


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_makereport(item: pytest.Item, call: pytest.CallInfo[None]) -> Iterator[None]:
    outcome = yield
    report = outcome.get_result()  # type: ignore[attr-defined]
    shown = getattr(item, "paramdds_page", None)
    if report.when == "call" and report.failed and shown is not None:
        tab, out = shown
        path = out / "failure.png"
        try:
            tab.screenshot(path=str(path), full_page=True)
            report.sections.append(("screenshot", str(path)))
        except Exception as exc:  # the page may be gone; the test's own failure matters more
            report.sections.append(("screenshot", f"could not be taken: {exc}"))
