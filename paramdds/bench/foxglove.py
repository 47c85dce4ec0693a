"""``paramdds bench foxglove``: a Foxglove Parameters panel's get-all and change latency,
``paramdds foxglove`` against foxglove_bridge's way over real ROS 2 nodes.

paramdds: for each N of ``--nodes`` (default 100, 1,000, 10,000 and the baseline's N),
server worker processes (1,000 node ids each at most, ``--params`` parameters each,
default 20, as the fleet bench hosts them) and a ``paramdds foxglove --port 0`` process;
a WebSocket client (``websockets``, which the foxglove extra installs; subprotocol
``foxglove.websocket.v1``, as ``@foxglove/ws-protocol`` and Lichtblick ask) waits until a
get-all holds every parameter, then, ``--rounds`` times, times

* ``fresh``: connect, ``serverInfo``, then ``getParameters []`` answered (a panel opening);
* ``warm``: one more ``getParameters []`` on that connection (the panel's refresh, every 15 s);

then ``--requests`` changes of ``bench_n0000``'s ``group0.param_000`` made by a paramdds
client in this process, each timed until the subscribed WebSocket client receives its
``parameterValues``: change to panel, p50 and p99.

foxglove_bridge's way: for each N of ``--ros-nodes`` (default 100 and 300; rclpy nodes
cost ~130 MB per 25 and their get-all took 3-5 s at 300 on the shared 2-core machine, so
larger N do not fit a bench run), rclpy host processes (``--servers``, default 4) hold the
same parameters, and one rclpy process does what ros-foxglove-bridge does for a get-all:
list and get per node, all nodes at once, a 5 s timeout per call
(:mod:`~paramdds.bench._foxglove_ros`); its change latency is a set until the change's
``/parameter_events`` message reaches it (the bridge's own WebSocket hop not counted).
"""

from __future__ import annotations

import argparse
import asyncio
import json
import re
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import IO, TYPE_CHECKING, Any

import yaml

from ._common import WorkerError, Workers, emit, median, note, percentile, render, run_timed, worker_env
from .worker import param_name, value_for

if TYPE_CHECKING:
    from websockets.asyncio.client import ClientConnection

SUBPROTOCOL = "foxglove.websocket.v1"
READY = re.compile(r"^\[FOXGLOVE\] Foxglove WebSocket server on (ws://\S+) \((\d+) nodes?\)$")
PER_SERVER = 1000  # node ids per server worker process
NODE0, PARAM0 = "bench_n0000", "group0.param_000"
PUSH_TIMEOUT = 5.0


def run(args: argparse.Namespace) -> int:
    quick = args.quick
    ros_counts = args.ros_nodes or ([10] if quick else [100, 300])
    counts = args.nodes or ([20] if quick else sorted({100, 1000, 10000, *ros_counts}))
    params = args.params or 20
    rounds = args.rounds or (2 if quick else 5)
    requests = args.requests or (20 if quick else 200)
    rows: dict[int, dict[str, Any]] = {}
    for n in counts:
        note(f"foxglove: paramdds, {n} nodes x {params} params")
        rows.setdefault(n, {"nodes": n})["paramdds"] = measure_paramdds(n, params, rounds, requests, args)
    from ..ros2 import missing

    ros_skipped = missing()
    if ros_skipped:
        note(f"foxglove: the ROS 2 baseline is skipped: {ros_skipped}")
    else:
        for n in ros_counts:
            note(f"foxglove: foxglove_bridge's way over rclpy, {n} nodes x {params} params")
            try:
                rows.setdefault(n, {"nodes": n})["ros"] = measure_ros(n, params, rounds, requests, args)
            except WorkerError as exc:  # rclpy or Fast DDS died: said in the output, the run goes on
                note(f"foxglove: the ROS 2 baseline at {n} nodes failed: {exc}")
                rows[n]["ros_error"] = str(exc)[:300]
    data = {
        "params_per_node": params,
        "rounds": rounds,
        "changes": requests,
        "ros_counts": [] if ros_skipped else ros_counts,
        "ros_skipped": ros_skipped or None,
        "rows": [rows[n] for n in sorted(rows)],
    }
    emit(args, data, table(data))
    return 0


# -- paramdds ---------------------------------------------------------------------------


def measure_paramdds(
    n: int, params: int, rounds: int, requests: int, args: argparse.Namespace
) -> dict[str, Any]:
    with Workers(localhost=args.localhost, domain=args.domain) as workers:
        servers = [
            workers.start(
                "server", "--nodes", str(min(PER_SERVER, n - k)), "--offset", str(k), "--params", str(params)
            )
            for k in range(0, n, PER_SERVER)
        ]
        for w in servers:
            w.read("READY", 120 + n / 50)
        with start_foxglove(args.domain, args.localhost, timeout=120 + n / 50) as fox:
            url = fox.match.group(1)
            result = asyncio.run(_paramdds_client(url, n, params, rounds, requests, args))
            result["ready_ms"] = fox.ready_ms
            result["ready_nodes"] = int(fox.match.group(2))
    result["servers"] = len(servers)
    return result


class ReadyProcess:
    """A front end's process started for a bench: ``match`` is its first stdout line matched
    against ``pattern`` (WorkerError if it differs or does not come within ``timeout``);
    ``close()`` sends SIGINT, as Ctrl-C, and waits for it to finish."""

    def __init__(self, cmd: list[str], pattern: re.Pattern[str], *, localhost: bool, timeout: float) -> None:
        self._err: IO[str] = tempfile.TemporaryFile("w+")  # noqa: SIM115 (closed by close())
        t0 = time.perf_counter()
        self.proc = subprocess.Popen(
            cmd,
            stdin=subprocess.DEVNULL,
            stdout=subprocess.PIPE,
            stderr=self._err,
            text=True,
            env=worker_env(localhost),
            start_new_session=True,
        )
        try:
            line = self.readline(timeout)
            match = pattern.match(line)
            if not match:
                raise WorkerError(f"{cmd[3:5]}: unexpected first line {line!r}{self.why()}")
        except BaseException:
            self.close()
            raise
        self.match = match
        self.ready_ms = round((time.perf_counter() - t0) * 1e3, 1)

    @property
    def pid(self) -> int:
        return self.proc.pid

    def readline(self, timeout: float) -> str:
        """The next stdout line within ``timeout`` (WorkerError if none)."""
        import selectors

        assert self.proc.stdout is not None
        with selectors.DefaultSelector() as sel:
            sel.register(self.proc.stdout, selectors.EVENT_READ)
            if not sel.select(timeout):
                raise WorkerError(f"{self.proc.args!r}: no line within {timeout:g} s{self.why()}")
        line = self.proc.stdout.readline()
        if not line:
            self.proc.wait(timeout=10)
            raise WorkerError(f"{self.proc.args!r} exited ({self.proc.returncode}){self.why()}")
        return line.strip()

    def why(self) -> str:
        self._err.seek(0)
        err = self._err.read().strip()
        return f"; stderr: {err[-800:]}" if err else ""

    def close(self, timeout: float = 15.0) -> int:
        """SIGINT, then wait (SIGKILL after ``timeout``); the exit code."""
        if self.proc.poll() is None:
            self.proc.send_signal(signal.SIGINT)
            try:
                self.proc.wait(timeout=timeout)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        if self.proc.stdout is not None:
            self.proc.stdout.close()
        self._err.close()
        return self.proc.returncode

    def __enter__(self) -> ReadyProcess:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def start_foxglove(domain: int, localhost: bool, timeout: float) -> ReadyProcess:
    """``paramdds foxglove --port 0``, once it printed its ready line."""
    cmd = [sys.executable, "-m", "paramdds.cli", "foxglove", "-d", str(domain), "--port", "0"]
    return ReadyProcess(
        [*cmd, "--localhost"] if localhost else cmd, READY, localhost=localhost, timeout=timeout
    )


async def _connect(url: str) -> ClientConnection:
    """A connection that has received the server's ``serverInfo``."""
    from websockets.asyncio.client import connect
    from websockets.typing import Subprotocol

    ws = await connect(url, subprotocols=[Subprotocol(SUBPROTOCOL)], max_size=None, compression=None)
    while (await _recv(ws)).get("op") != "serverInfo":
        pass
    return ws


async def _recv(ws: ClientConnection) -> dict[str, Any]:
    """The next JSON text message (binary ones skipped)."""
    while True:
        data = await ws.recv()
        if isinstance(data, str):
            message: dict[str, Any] = json.loads(data)
            return message


async def _send(ws: ClientConnection, message: dict[str, Any]) -> None:
    await ws.send(json.dumps(message))


async def _get_all(ws: ClientConnection, rid: str) -> list[dict[str, Any]]:
    await _send(ws, {"op": "getParameters", "parameterNames": [], "id": rid})
    while True:
        message = await _recv(ws)
        if message.get("op") == "parameterValues" and message.get("id") == rid:
            parameters: list[dict[str, Any]] = message["parameters"]
            return parameters


async def _paramdds_client(
    url: str, n: int, params: int, rounds: int, requests: int, args: argparse.Namespace
) -> dict[str, Any]:
    want = n * params
    t0 = time.perf_counter()
    deadline = time.monotonic() + 60 + n / 100
    ws = await _connect(url)
    while len(got := await _get_all(ws, "full")) < want:
        if time.monotonic() > deadline:
            raise WorkerError(f"foxglove: a get-all held {len(got)} of {want} parameters")
        await asyncio.sleep(0.2)
    full_ms = (time.perf_counter() - t0) * 1e3
    await ws.close()
    fresh: list[float] = []
    warm: list[float] = []
    for r in range(rounds):
        t0 = time.perf_counter()
        ws = await _connect(url)
        got = await _get_all(ws, f"fresh{r}")
        fresh.append((time.perf_counter() - t0) * 1e3)
        t0 = time.perf_counter()
        got = await _get_all(ws, f"warm{r}")
        warm.append((time.perf_counter() - t0) * 1e3)
        await ws.close()
        if len(got) != want:
            raise WorkerError(f"foxglove: a get-all held {len(got)} of {want} parameters")
    reply_bytes = len(json.dumps({"op": "parameterValues", "parameters": got, "id": "warm"}))
    latency, lost = await _change_latency(url, requests, args)
    return {
        "params": len(got),
        "full_ms": round(full_ms, 1),
        "fresh_ms": [round(v, 1) for v in fresh],
        "warm_ms": [round(v, 1) for v in warm],
        "reply_bytes": reply_bytes,
        "change_ms": {"p50": round(percentile(latency, 50), 2), "p99": round(percentile(latency, 99), 2)},
        "changes_lost": lost,
    }


async def _change_latency(url: str, requests: int, args: argparse.Namespace) -> tuple[list[float], int]:
    """Changes made by a paramdds client in this process, each timed until the subscribed
    WebSocket client receives it."""
    from ..dds.client import ParameterClient
    from ..dds.participant import make_participant

    dp = make_participant(args.domain, localhost=args.localhost, app_name="bench-foxglove")
    client = ParameterClient(dp, timeout=PUSH_TIMEOUT)
    name = f"/{NODE0}.{PARAM0}"
    ws = await _connect(url)
    loop = asyncio.get_running_loop()
    samples: list[float] = []
    lost = 0
    try:
        await loop.run_in_executor(None, client.wait_for_node, NODE0, 20.0)
        await _send(ws, {"op": "subscribeParameterUpdates", "parameterNames": [name]})
        warm = max(1, requests // 10)
        for i in range(requests + warm):
            value = 100.0 + i * 0.5
            t0 = time.perf_counter()
            done = loop.run_in_executor(None, client.set, NODE0, {PARAM0: value})
            try:
                await asyncio.wait_for(_pushed(ws, name, value), PUSH_TIMEOUT)
            except asyncio.TimeoutError:
                lost += 1
                await done
                continue
            took = (time.perf_counter() - t0) * 1e3
            await done
            if i >= warm:
                samples.append(took)
    finally:
        await ws.close()
        client.close()
    if not samples:
        raise WorkerError(f"foxglove: none of {requests} changes reached the subscribed client")
    return samples, lost


async def _pushed(ws: ClientConnection, name: str, value: float) -> None:
    while True:
        message = await _recv(ws)
        if message.get("op") != "parameterValues" or "id" in message:
            continue
        if any(p.get("name") == name and p.get("value") == value for p in message["parameters"]):
            return


# -- foxglove_bridge's way over rclpy ---------------------------------------------------


def ros_params_file(path: Path, nodes: list[str], params: int) -> None:
    """A ROS 2 parameter file giving each of ``nodes`` the bench's ``params`` parameters."""
    doc: dict[str, Any] = {}
    for node in nodes:
        tree: dict[str, Any] = {}
        for j in range(params):
            group, _, leaf = param_name(j).partition(".")
            tree.setdefault(group, {})[leaf] = value_for(j)
        doc[f"/{node}"] = {"ros__parameters": tree}
    path.write_text(yaml.safe_dump(doc, sort_keys=False))


def measure_ros(n: int, params: int, rounds: int, requests: int, args: argparse.Namespace) -> dict[str, Any]:
    from ._common import node_names
    from .ros2 import Host, ros_env, ros_host

    hosts = min(args.servers or 4, n)
    names = node_names(n)
    with tempfile.TemporaryDirectory(prefix="paramdds-bench-foxglove-") as tmpdir:
        tmp = Path(tmpdir)
        env = ros_env(tmp)
        started: list[Host] = []
        try:
            for h in range(hosts):
                path = tmp / f"host{h}.yaml"
                ros_params_file(path, names[h::hosts], params)
                started.append(ros_host(path, env))
            cmd = [sys.executable, "-m", "paramdds.bench._foxglove_ros", str(n), str(rounds), str(requests)]
            _, out = run_timed(cmd, env=env, timeout=300 + n)
        finally:
            for host in started:
                host.stop()
    result: dict[str, Any] = json.loads(out.strip().splitlines()[-1])
    latency = result.pop("latency_ms")
    result["change_ms"] = (
        {"p50": round(percentile(latency, 50), 2), "p99": round(percentile(latency, 99), 2)}
        if latency
        else None
    )
    result["hosts"] = hosts
    return result


# -- output -----------------------------------------------------------------------------


def _span(values: list[float]) -> str:
    return f"{median(values):,.1f} ({min(values):,.1f}-{max(values):,.1f})"


def table(data: dict[str, Any]) -> str:
    heads = ["N", "measure", "paramdds foxglove", "foxglove_bridge way (rclpy)", "ratio"]
    body: list[list[object]] = []
    for row in data["rows"]:
        n, dds, ros = row["nodes"], row.get("paramdds"), row.get("ros")
        ros_ms = ros["round_ms"][1:] or ros["round_ms"] if ros else None
        if dds:
            body.append([n, "parameters in a get-all", dds["params"], ros["params"][-1] if ros else "-", "-"])
            ratio = f"{median(ros_ms) / median(dds['warm_ms']):.1f}x" if ros_ms else "-"
            body.append(
                [
                    n,
                    "get-all, open connection (ms)",
                    _span(dds["warm_ms"]),
                    _span(ros_ms) if ros_ms else "-",
                    ratio,
                ]
            )
            body.append([n, "get-all, fresh connection (ms)", _span(dds["fresh_ms"]), "-", "-"])
            start = f"{dds['ready_ms'] + dds['full_ms']:,.0f} ({dds['ready_nodes']} at ready)"
            body.append([n, "server start until a get-all holds all (ms)", start, "-", "-"])
            body.append([n, "get-all reply (bytes)", f"{dds['reply_bytes']:,}", "-", "-"])
        elif ros and ros_ms:
            body.append([n, "parameters in a get-all", "-", ros["params"][-1], "-"])
            body.append([n, "get-all, open connection (ms)", "-", _span(ros_ms), "-"])
        for q in ("p50", "p99"):
            a = dds["change_ms"][q] if dds else None
            b = ros["change_ms"][q] if ros and ros["change_ms"] else None
            ratio = f"{b / a:.1f}x" if a and b else "-"
            body.append(
                [n, f"change -> client {q} (ms)", "-" if a is None else a, "-" if b is None else b, ratio]
            )
        if row.get("ros_error"):
            body.append([n, "ROS 2 baseline failed", "-", row["ros_error"][:60], "-"])
        if ros:
            body.append(
                [
                    n,
                    "nodes answered / ignored (ROS 2)",
                    "-",
                    f"{min(ros['answered'])} / {ros['ignored']}",
                    "-",
                ]
            )
    lines = [
        f"Foxglove get-all and change latency: {data['params_per_node']} params per node, "
        f"median (min-max) of {data['rounds']} rounds; {data['changes']} changes",
    ]
    if data["ros_skipped"]:
        lines.append(f"ROS 2 baseline skipped: {data['ros_skipped']}")
    else:
        lines.append(
            "ROS 2 baseline at N = "
            + ", ".join(map(str, data["ros_counts"]))
            + " only (rclpy nodes: larger N do not fit this machine in a bench run); the rclpy "
            "process's first round (its first call on each client) is left out of its get-all times"
        )
    return "\n".join(lines) + "\n" + render(heads, body)
