"""The ``--persist`` file: damage is refused loudly, writes are never half done.

Proves: a truncated, corrupted, non-YAML or ill-typed persistence file stops
``paramdds server`` with exit code 2 and one line naming the file and the
problem, and the file is left byte for byte as it was (never replaced by
defaults); a crash between the temporary write and the rename leaves the old
file intact; and SIGKILL at random moments during a stream of sets always
leaves a file that loads and holds at least every acknowledged change, also
while the store compacts its journal every other change; a second server on the
same file refuses to start and names the holder; changes the application makes
itself are persisted too.
"""

from __future__ import annotations

import os
import random
import subprocess
import sys
import textwrap
import threading
import time
from pathlib import Path

import pytest

from paramdds.core.descriptors import ParameterDescriptor
from paramdds.core.table import ParameterTable
from paramdds.core.values import Parameter, ParameterValue
from paramdds.dds.client import ParameterClient
from paramdds.errors import ErrorCode, ParamddsError
from paramdds.formats.files import dump_text, parse_ros_text
from paramdds.persist import HEADER, PersistStore, frame, unframe

from .conftest import DDS, PARAMDDS, Proc, make_dds_env, other_domain, start_server

NODE = "robot"


def _store(path: Path) -> PersistStore:
    """The store exactly as ``paramdds server --persist`` builds it."""
    return PersistStore(path, dumper=lambda s: dump_text(s, with_descriptors=True), parser=parse_ros_text)


def _valid_state(path: Path) -> bytes:
    """A persistence file written by the server's own code path (what a running server leaves)."""
    table = ParameterTable(NODE)
    table.declare("robot.max_velocity", 2.5)
    table.declare("robot.name", "persisted")
    table.declare("robot.enabled", True)
    table.declare("robot.wheel_count", 6)
    table.declare("sensor.frame_ids", ["a", "b"])
    store = _store(path)
    store.attach({NODE: table})
    store.close()
    return path.read_bytes()


def _corrupt(raw: bytes) -> bytes:
    middle = len(raw) // 2
    flipped = b"X" if raw[middle : middle + 1] != b"X" else b"Y"
    return raw[:middle] + flipped + raw[middle + 1 :]


def _reframed(raw: bytes, old: str, new: str) -> bytes:
    """The server's own file with ``old`` replaced by ``new`` and a checksum that matches again
    (an edit by a tool that knows the frame, or a bug: the content is what is wrong)."""
    body = unframe(raw, "x")[len(HEADER) :]
    assert old in body
    return frame(body.replace(old, new)).encode()


SPEC = """\
robot_params:
  robot:
    wheel_count:
      type: int
      default_value: 4
    name:
      type: string
      default_value: "r"
"""

# name -> (how to damage a valid file, words the message must contain, start with --spec)
DAMAGE = {
    "truncated-half": (lambda raw: raw[: len(raw) // 2], "truncated", False),
    "truncated-empty": (lambda raw: b"", "empty", False),
    "truncated-in-end-line": (lambda raw: raw[:-12], "truncated", False),
    "one-byte-changed": (_corrupt, "checksum", False),
    "not-utf8": (lambda raw: b"\xff\xfe\x00garbage", "UTF-8", False),
    "not-yaml-framed": (lambda raw: frame("robot: [unclosed\n  ros__parameters: {\n").encode(), "", False),
    "not-yaml-hand-written": (lambda raw: b"robot:\n  ros__parameters: [1, 2\n  : }\n", "", False),
    "not-a-parameter-file": (lambda raw: frame("- just\n- a list\n").encode(), "", False),
    "wrong-type-vs-own-descriptor": (
        lambda raw: _reframed(raw, "wheel_count: 6", "wheel_count: four"),
        "wheel_count",
        False,
    ),
    "wrong-type-vs-spec": (
        lambda raw: frame("robot:\n  ros__parameters:\n    robot:\n      wheel_count: four\n").encode(),
        "wheel_count",
        True,
    ),
    "wrong-type-vs-params-file": (
        lambda raw: frame("robot:\n  ros__parameters:\n    robot:\n      wheel_count: four\n").encode(),
        "wheel_count",
        False,
    ),
}


def _run_until_exit(argv: list[str], env: dict[str, str], timeout: float = 6.0) -> tuple[int, str, str]:
    """Run a server that is expected to refuse; one that starts anyway is stopped and fails the test."""
    proc = subprocess.Popen(argv, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        out, err = proc.communicate(timeout=timeout)
    except subprocess.TimeoutExpired:
        proc.kill()
        out, err = proc.communicate()
        raise AssertionError(f"the server started on a damaged file: {out!r}") from None
    return proc.returncode, out, err


@pytest.mark.timeout(60)
@pytest.mark.parametrize("damage", sorted(DAMAGE))
def test_damaged_persistence_file_refuses_start_and_is_left_untouched(
    damage: str, domain_id: int, params_file: Path, tmp_path: Path
) -> None:
    state = tmp_path / "state.yaml"
    make, words, with_spec = DAMAGE[damage]
    state.write_bytes(make(_valid_state(state)))
    before = state.read_bytes()
    sources = ["-p", str(params_file)]
    if with_spec:
        (tmp_path / "spec.yaml").write_text(SPEC)
        sources = ["--spec", str(tmp_path / "spec.yaml")]
    files_before = sorted(p.name for p in tmp_path.iterdir())

    code, out, err = _run_until_exit(
        [PARAMDDS, "server", "-n", NODE, *sources, "--persist", str(state)], make_dds_env(domain_id)
    )

    assert code == 2, (code, out, err)
    assert "[SERVER] Serving" not in out
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("paramdds: error:"), err
    assert "Traceback" not in err
    assert str(state) in lines[0], f"the message does not name the file: {lines[0]}"
    assert words.lower() in lines[0].lower(), f"the message does not say {words!r}: {lines[0]}"
    assert state.read_bytes() == before, "the damaged file was modified"
    assert sorted(p.name for p in tmp_path.iterdir()) == files_before, "files were added or removed"


CRASH_BEFORE_RENAME = textwrap.dedent(
    """
    import os, sys
    from paramdds import persist
    def crash(src, dst):  # the power goes out after the temp file is written and fsynced
        os._exit(9)
    os.replace = crash
    persist.atomic_write(persist.Path(sys.argv[1]), persist.frame("robot:\\n  ros__parameters:\\n"
        "    robot:\\n      name: never-renamed\\n"))
    """
)


@pytest.mark.timeout(60)
def test_crash_between_temp_write_and_rename_keeps_the_old_file(
    domain_id: int, params_file: Path, tmp_path: Path, dds: DDS, procs: list[Proc]
) -> None:
    state = tmp_path / "state.yaml"
    before = _valid_state(state)
    crashed = subprocess.run(
        [sys.executable, "-c", CRASH_BEFORE_RENAME, str(state)], capture_output=True, text=True, timeout=30
    )
    assert crashed.returncode == 9, crashed.stderr
    assert state.read_bytes() == before
    leftovers = [p.name for p in tmp_path.iterdir() if p.name.endswith(".tmp")]
    assert leftovers, "the simulated crash did not happen after the temp write"

    # the old state loads (the stray temp file is ignored) and is what the node serves
    server = start_server(domain_id, "-n", NODE, "-p", str(params_file), "--persist", str(state))
    procs.append(server)
    client = dds.client(domain_id, timeout=3.0)
    client.wait_for_node(NODE, timeout=10)
    assert client.get_value(NODE, "robot.name") == ParameterValue.from_python("persisted")


def _persisted(state: Path) -> dict[str, ParameterValue]:
    """What a restart loads (snapshot and journal), read without taking the lock."""
    return {name: value for name, value, _ in _store(state).read(NODE)}


def _stream_sets(
    client: ParameterClient, stop: threading.Event, acked: list[int], sent: list[int], first: int
) -> None:
    i = first
    while not stop.is_set():
        sent.append(i)
        try:
            # the name's length varies, so a torn write would show in the file's size and checksum
            reply = client.set(NODE, {"robot.wheel_count": i, "robot.name": f"v{i}-" + "x" * (i % 97)})
        except ParamddsError:
            return  # the server is gone
        if reply.successful:
            acked.append(i)
        i += 1


@pytest.mark.slow
@pytest.mark.timeout(120)
@pytest.mark.parametrize("compact_every", ["10000", "2"], ids=["journal", "compacting"])
def test_sigkill_during_a_stream_of_sets_never_leaves_a_broken_file(
    compact_every: str, domain_id: int, params_file: Path, tmp_path: Path, dds: DDS, procs: list[Proc]
) -> None:
    # "compacting": a new snapshot every second change, so most kills land in or near one
    state = tmp_path / "state.yaml"
    args = ("-n", NODE, "-p", str(params_file), "--persist", str(state))
    env = make_dds_env(domain_id, PARAMDDS_PERSIST_COMPACT_EVERY=compact_every)
    client = dds.client(domain_id, timeout=2.0)
    rng = random.Random(6 + len(compact_every))
    first = 1000
    for _round in range(6):
        server = start_server(domain_id, *args, env=env)  # a broken file would fail this start (exit 2)
        procs.append(server)
        client.wait_for_node(NODE, timeout=10)
        stop = threading.Event()
        acked: list[int] = []
        sent: list[int] = []
        writer = threading.Thread(target=_stream_sets, args=(client, stop, acked, sent, first), daemon=True)
        writer.start()
        assert _wait(lambda: len(acked) >= 5, 10)  # noqa: B023
        time.sleep(rng.uniform(0.0, 0.25))
        server.kill()
        stop.set()
        writer.join(10)
        assert acked, "no set was acknowledged"
        values = _persisted(state)  # raises if the file is torn
        stored = values["robot.wheel_count"].value
        assert isinstance(stored, int)
        # written before the reply: nothing acknowledged is lost, nothing unsent appears
        assert acked[-1] <= stored <= sent[-1], (acked[-1], stored, sent[-1])
        assert values["robot.name"].value == f"v{stored}-" + "x" * (stored % 97)
        first = sent[-1] + 1
        # wait until the client sees the node gone, so the next round's wait means the new server
        assert _wait(lambda: not (client.node_info(NODE) and client.node_info(NODE).online), 5)
    assert state.read_bytes().startswith(b"# paramdds persisted state")


def _wait(predicate: object, timeout: float) -> bool:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if predicate():  # type: ignore[operator]
            return True
        time.sleep(0.01)
    return bool(predicate())  # type: ignore[operator]


@pytest.mark.timeout(30)
def test_a_failed_persistence_write_is_not_persisted_not_an_internal_error(
    tmp_path: Path, domain_id: int, dds: DDS
) -> None:
    state = tmp_path / "state.yaml"
    table = ParameterTable(NODE)
    table.declare("robot.max_velocity", 1.0)
    store = _store(state)
    store.attach({NODE: table})
    server = dds.server(domain_id, table)
    server.persisters.append(store.record)
    client = dds.client(domain_id, timeout=5.0)
    client.wait_for_node(NODE)

    journal = store._journal  # the disk fills up: every write to the journal fails with ENOSPC
    assert journal is not None
    saved = os.dup(journal.fd)
    full = os.open("/dev/full", os.O_WRONLY)
    os.dup2(full, journal.fd)
    reply = client.set(NODE, {"robot.max_velocity": 2.0, "nope": 1})
    # per-parameter results, as always: the applied one says NOT_PERSISTED, the other its own reason
    by_name = {r.name: r for r in reply.results}
    assert by_name["robot.max_velocity"].code is ErrorCode.NOT_PERSISTED
    assert not by_name["robot.max_velocity"].successful
    message = by_name["robot.max_velocity"].reason
    assert "applied at revision" in message and "not persisted" in message
    assert by_name["nope"].code is ErrorCode.NOT_FOUND
    assert table.get("robot.max_velocity").value == 2.0  # applied, as the message says
    assert client.get(NODE, ["robot.max_velocity"]).values()["robot.max_velocity"].value == 2.0

    os.dup2(saved, journal.fd)  # the disk recovers: the next change persists the whole table again
    os.close(saved)
    os.close(full)
    client.set(NODE, {"robot.max_velocity": 3.0})
    assert _persisted(state)["robot.max_velocity"] == ParameterValue.from_python(3.0)
    assert "3.0" in state.read_text()  # by a compaction: the snapshot itself holds it
    assert sorted(p.name for p in tmp_path.iterdir()) == ["state.yaml", "state.yaml.journal"]
    store.close()


@pytest.mark.timeout(60)
def test_a_second_server_on_the_same_file_refuses_and_names_the_holder(
    domain_id: int, params_file: Path, tmp_path: Path, procs: list[Proc]
) -> None:
    state = tmp_path / "state.yaml"
    args = ["-n", NODE, "-p", str(params_file), "--persist", str(state)]
    first = start_server(domain_id, *args)
    procs.append(first)
    before = state.read_bytes()
    code, out, err = _run_until_exit([PARAMDDS, "server", *args], make_dds_env(other_domain(domain_id)))
    assert code == 2, (code, out, err)
    assert f"pid {first.pid}" in err and str(state) in err, err
    assert state.read_bytes() == before
    assert first.stop() == 0
    # positive control: once the holder is gone, the same command starts
    procs.append(start_server(domain_id, *args))


@pytest.mark.timeout(30)
def test_changes_made_by_the_application_itself_are_persisted(
    tmp_path: Path, domain_id: int, dds: DDS
) -> None:
    state = tmp_path / "state.yaml"
    table = ParameterTable(NODE, allow_undeclared=True)
    table.declare("robot.max_velocity", 1.0)
    table.declare("scratch", 1, ParameterDescriptor("scratch", dynamic_typing=True))
    store = _store(state)
    store.attach({NODE: table})
    server = dds.server(domain_id, table)
    server.persisters.append(store.record)
    try:
        client = dds.client(domain_id, timeout=5.0)
        client.wait_for_node(NODE)
        client.set(NODE, {"robot.max_velocity": 2.0})  # positive control: over DDS
        assert _persisted(state)["robot.max_velocity"].value == 2.0
        table.set([Parameter("robot.max_velocity", ParameterValue.from_python(4.0))])  # in-process
        table.declare("added.later", "x")
        table.undeclare("scratch")
        assert _wait(lambda: "added.later" in _persisted(state), 5.0)
        persisted = _persisted(state)
        assert persisted["robot.max_velocity"].value == 4.0
        assert "scratch" not in persisted and store.deleted(NODE) == ["scratch"]
        # and they are published too, after the disk
        assert client.get_value(NODE, "robot.max_velocity").value == 4.0
    finally:
        store.close()
