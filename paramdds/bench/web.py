"""``paramdds bench web``: the browser console, measured in headless Chromium.

Two figures, each beside a baseline from the same run:

* **set → DOM**: a client in this process sets one parameter of a node shown in
  the page (``--requests`` times, default 200); measured from the moment the set
  is acknowledged to the moment a MutationObserver in the page sees the new value
  in the DOM (both read the wall clock of this machine). Baseline: from the same
  acknowledgement to a :class:`ParameterMonitor` in this process seeing the change
  (what the console's own monitor can do at best, before HTTP and the browser).
* **first render**: a fresh page load of the console while ``--nodes`` node ids x
  ``--params`` parameters (default 1000 x 50) are online: navigation start until
  the first page of the node list is in the DOM (median of ``--rounds``, default 3).
  Baseline: the same page's ``GET /api/nodes`` alone, timed from this process.

Servers run as bench workers; the console is a real ``paramdds web`` process; the
browser is Debian's ``chromium`` (``PARAMDDS_CHROMIUM`` overrides the path).
"""

from __future__ import annotations

import argparse
import contextlib
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time
import urllib.request
from collections.abc import Iterator
from typing import Any

from ._common import Workers, emit, median, node_names, note, percentile, render, worker_env

CHROMIUM_FLAGS = [
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
]
TARGET_P50_MS = 100.0
TARGET_FIRST_RENDER_MS = 1500.0
PARAM = "group0.param_001"  # an integer parameter of the bench worker's tables

# Resolves when the row of window.__want.name shows window.__want.text; records the wall clock.
_OBSERVE = """
() => {
  window.__seen = null;
  const check = () => {
    const w = window.__want;
    if (!w || window.__seen !== null) return;
    const cell = document.querySelector(`#params tbody tr[data-name="${w.name}"] .current`);
    if (cell && cell.textContent === w.text) window.__seen = performance.timeOrigin + performance.now();
  };
  new MutationObserver(check).observe(document.querySelector("#params tbody"),
    { childList: true, subtree: true, characterData: true });
  window.__check = check;
}
"""


def _chromium() -> str:
    path = os.environ.get("PARAMDDS_CHROMIUM") or shutil.which("chromium") or "/usr/bin/chromium"
    if not os.path.exists(path):
        raise RuntimeError(f"no Chromium at {path}: apt-get install chromium (or set PARAMDDS_CHROMIUM)")
    return path


@contextlib.contextmanager
def console(domain: int, localhost: bool) -> Iterator[str]:
    """A ``paramdds web`` process on a free loopback port; yields its URL."""
    cmd = [sys.executable, "-m", "paramdds.cli", "-d", str(domain), "web", "--bind", "127.0.0.1:0"]
    if localhost:
        cmd.append("--localhost")
    proc = subprocess.Popen(
        cmd,
        stdout=subprocess.PIPE,
        stderr=subprocess.DEVNULL,
        text=True,
        start_new_session=True,
        env=worker_env(localhost),
    )
    try:
        assert proc.stdout is not None
        line = proc.stdout.readline()
        match = re.search(r"http://\S+/", line)
        if match is None:
            raise RuntimeError(f"paramdds web did not start: {line!r}")
        yield match.group(0)
    finally:
        with contextlib.suppress(ProcessLookupError):
            os.killpg(proc.pid, signal.SIGTERM)
        try:
            proc.wait(5)
        except subprocess.TimeoutExpired:
            with contextlib.suppress(ProcessLookupError):
                os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
        if proc.stdout is not None:
            proc.stdout.close()


def _poll(page: Any, expression: str, timeout: float) -> Any:
    """Evaluate ``expression`` until it is not null (the console's CSP forbids the string
    evaluation of ``wait_for_function``; times are recorded in the page, so polling adds nothing)."""
    deadline = time.monotonic() + timeout
    while True:
        value = page.evaluate(expression)
        if value is not None:
            return value
        if time.monotonic() > deadline:
            raise RuntimeError(f"the page did not get {expression!r} within {timeout:g} s")
        time.sleep(0.002)


def _get_json_ms(url: str) -> tuple[float, bytes]:
    t0 = time.perf_counter()
    with urllib.request.urlopen(url, timeout=30) as r:
        body: bytes = r.read()
    return (time.perf_counter() - t0) * 1e3, body


def _wait_listed(url: str, nodes: int, params: int, timeout: float) -> None:
    import json

    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        _, body = _get_json_ms(url + "api/nodes?limit=200&q=")
        data = json.loads(body)
        if data["total"] >= nodes and all(n["parameters"] == params for n in data["nodes"]):
            return
        time.sleep(0.2)
    raise RuntimeError(f"the console did not list {nodes} nodes within {timeout:g} s")


def _latency(args: argparse.Namespace, browser: Any, requests: int) -> dict[str, float]:
    from ..dds.client import ParameterClient
    from ..dds.monitor import MonitorEvent, ParameterMonitor
    from ..dds.participant import close_participant, make_participant
    from ..dds.qos import QosProfiles

    (node,) = node_names(1)
    with Workers(localhost=args.localhost, domain=args.domain) as workers:
        server = workers.start("server", "--nodes", "1", "--params", "50")
        server.read("READY", 120)
        with console(args.domain, args.localhost) as url:
            _wait_listed(url, 1, 50, 60)
            page = browser.new_page()
            page.goto(f"{url}#node={node}")
            page.wait_for_selector(f'#params tbody tr[data-name="{PARAM}"]')
            _poll(page, "() => document.querySelector('#stream-state').textContent === 'live' || null", 30)
            page.evaluate(_OBSERVE)
            qos = QosProfiles.load()
            dp = make_participant(args.domain, localhost=args.localhost, app_name="bench-web")
            seen: dict[int, float] = {}
            event = threading.Event()

            def on_event(e: MonitorEvent) -> None:
                if e.node == node and e.name == PARAM and e.value is not None:
                    seen.setdefault(int(e.value.value), time.time())  # type: ignore[arg-type]
                    event.set()

            monitor = ParameterMonitor(dp, qos, nodes=[node], on_event=on_event)
            client = ParameterClient(dp, qos, timeout=args.timeout)
            dom_ms: list[float] = []
            monitor_ms: list[float] = []
            try:
                client.wait_for_node(node)
                for i in range(requests):
                    value = 1_000_000 + i
                    page.evaluate(
                        "w => { window.__want = w; window.__seen = null; }",
                        {"name": PARAM, "text": str(value)},
                    )
                    client.set(node, {PARAM: value})
                    acked = time.time()
                    shown = _poll(page, "() => window.__seen", 10) / 1e3
                    dom_ms.append(max(0.0, (shown - acked) * 1e3))
                    event.wait(5)
                    event.clear()
                    monitor_ms.append(max(0.0, (seen.get(value, acked) - acked) * 1e3))
            finally:
                client.close()
                monitor.close()
                close_participant(dp)
                page.close()
    return {
        "dom_p50_ms": round(percentile(dom_ms, 50), 1),
        "dom_p99_ms": round(percentile(dom_ms, 99), 1),
        "monitor_p50_ms": round(percentile(monitor_ms, 50), 2),
        "monitor_p99_ms": round(percentile(monitor_ms, 99), 2),
        "changes": len(dom_ms),
    }


def _first_render(
    args: argparse.Namespace, browser: Any, nodes: int, params: int, rounds: int
) -> dict[str, float]:
    with Workers(localhost=args.localhost, domain=args.domain) as workers:
        server = workers.start("server", "--nodes", str(nodes), "--params", str(params))
        server.read("READY", 300)
        with console(args.domain, args.localhost) as url:
            _wait_listed(url, nodes, params, 180)
            render_ms: list[float] = []
            api_ms: list[float] = []
            for _ in range(rounds):
                page = browser.new_page()
                page.goto(url)
                render_ms.append(_poll(page, "() => window.paramddsFirstRender ?? null", 30))
                if page.locator("#nodes li").count() != min(50, nodes):
                    raise RuntimeError("the first page of the node list is incomplete")
                page.close()
                api_ms.append(_get_json_ms(url + "api/nodes?q=&offset=0&limit=50")[0])
    return {"first_render_ms": round(median(render_ms), 1), "api_nodes_ms": round(median(api_ms), 1)}


def run(args: argparse.Namespace) -> int:
    from playwright.sync_api import sync_playwright

    requests = args.requests or (20 if args.quick else 200)
    nodes = (args.nodes or [100 if args.quick else 1000])[0]
    params = args.params or 50
    rounds = args.rounds or (1 if args.quick else 3)
    profile = tempfile.mkdtemp(prefix="paramdds-bench-chromium-")
    try:
        with sync_playwright() as p:
            browser = p.chromium.launch_persistent_context(
                profile,
                executable_path=_chromium(),
                args=CHROMIUM_FLAGS,
                viewport={"width": 1280, "height": 800},
            )
            try:
                note(f"web: {requests} sets of a shown parameter, CLI ack → DOM")
                latency = _latency(args, browser, requests)
                note(f"web: first render with {nodes} nodes x {params} params online")
                first = _first_render(args, browser, nodes, params, rounds)
            finally:
                browser.close()
    finally:
        shutil.rmtree(profile, ignore_errors=True)
    data: dict[str, Any] = {
        **latency,
        **first,
        "nodes": nodes,
        "params_per_node": params,
        "rounds": rounds,
        "targets": {"dom_p50_ms": TARGET_P50_MS, "first_render_ms": TARGET_FIRST_RENDER_MS},
    }
    table = render(
        ["figure", "value", "baseline (same run)", "target"],
        [
            (
                "set ack → value in DOM, p50 ms",
                latency["dom_p50_ms"],
                f"monitor {latency['monitor_p50_ms']}",
                "≤ 100",
            ),
            (
                "set ack → value in DOM, p99 ms",
                latency["dom_p99_ms"],
                f"monitor {latency['monitor_p99_ms']}",
                "",
            ),
            (
                f"first render, {nodes} x {params}, ms",
                first["first_render_ms"],
                f"GET /api/nodes {first['api_nodes_ms']}",
                "≤ 1500",
            ),
        ],
    )
    emit(args, data, table)
    return 0
