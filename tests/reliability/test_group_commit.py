"""Group commit: concurrent sets share one ``fdatasync``, and no reply leaves before its flush.

The journal's flush is made observable (and slow, 50 ms, so that a reply sent early
would reach its client long before the flush ends): after each real ``fdatasync``
the test reads the journal file back and records the revisions it holds, per node.
A client that gets a reply checks at once that its revision is among them.

* One client, one set at a time: every acknowledged revision is on disk when the reply
  arrives.
* Eight clients at once on four nodes of one server (two per node): the same holds for
  every reply, and the 80 sets needed far fewer flushes than sets (commits of one node
  share its worker's persist call, appends of several nodes share a flush); a ninth
  client getting a node's value meanwhile never reads a revision that is not on disk.
"""

from __future__ import annotations

import json
import threading
import time
from pathlib import Path
from typing import Any

import pytest

from paramdds.core.table import ParameterTable
from paramdds.formats.files import dump_text, parse_ros_text
from paramdds.persist import PersistStore

from .conftest import DDS

FLUSH_S = 0.05


class ObservedFlushes:
    """Wraps the store's journal: each flush is slow, and afterwards records what is on disk."""

    def __init__(self, store: PersistStore) -> None:
        journal = store._journal
        assert journal is not None
        self.path = store.journal_path
        self.count = 0
        self.durable: dict[str, set[int]] = {}
        self._lock = threading.Lock()
        real = journal.sync

        def sync() -> None:
            time.sleep(FLUSH_S)  # a slow disk: a reply sent before the flush would arrive first
            real()
            self._record()

        journal.sync = sync  # type: ignore[method-assign]

    def _record(self) -> None:
        durable: dict[str, set[int]] = {}
        raw = self.path.read_bytes().split(b"\0", 1)[0]  # up to the preallocated zeros
        for line in raw.split(b"\n")[1:]:  # after the epoch line: "<crc32> [node, revision, entries]"
            if line:
                node, revision, _ = json.loads(line.split(b" ", 1)[1])
                durable.setdefault(node, set()).add(revision)
        with self._lock:
            self.count += 1
            self.durable = durable

    def holds(self, node: str, revision: int) -> bool:
        with self._lock:
            return revision in self.durable.get(node, set())


def _served(
    tmp_path: Path, domain_id: int, dds: DDS, nodes: list[str]
) -> tuple[PersistStore, ObservedFlushes]:
    tables = {}
    for node in nodes:
        table = ParameterTable(node)
        table.declare("x", 0)
        tables[node] = table
    store = PersistStore(
        tmp_path / "state.yaml",
        dumper=lambda s: dump_text(s, with_descriptors=True),
        parser=parse_ros_text,
    )
    store.attach(tables)
    server = dds.server(domain_id, *tables.values())
    server.persisters.append(store.record)
    return store, ObservedFlushes(store)


def _set_many(client: Any, node: str, values: range, observed: ObservedFlushes, early: list[str]) -> None:
    client.wait_for_node(node, timeout=10)
    for v in values:
        reply = client.set(node, {"x": v})
        assert reply.successful, reply.results
        if not observed.holds(node, reply.revision):  # checked the moment the reply is in
            early.append(f"{node} r{reply.revision}")


@pytest.mark.timeout(60)
def test_no_reply_leaves_before_its_record_is_flushed(tmp_path: Path, domain_id: int, dds: DDS) -> None:
    store, observed = _served(tmp_path, domain_id, dds, ["solo"])
    early: list[str] = []
    _set_many(dds.client(domain_id, timeout=5.0), "solo", range(1, 21), observed, early)
    assert not early, f"replies before their flush: {early}"
    assert observed.count >= 20  # one client, one set at a time: nothing to share
    store.close()


@pytest.mark.timeout(90)
def test_concurrent_clients_share_flushes_and_each_reply_follows_its_own(
    tmp_path: Path, domain_id: int, dds: DDS
) -> None:
    nodes = [f"n{i}" for i in range(4)]
    store, observed = _served(tmp_path, domain_id, dds, nodes)
    clients = [dds.client(domain_id, timeout=10.0) for _ in range(8)]
    for client, node in zip(clients, nodes * 2, strict=True):
        client.wait_for_node(node, timeout=10)
    early: list[str] = []
    failed: list[BaseException] = []

    def lane(i: int) -> None:
        try:
            _set_many(clients[i], nodes[i % 4], range(100 * i, 100 * i + 10), observed, early)
        except BaseException as exc:  # reported below, not lost in the thread
            failed.append(exc)

    reader = dds.client(domain_id, timeout=10.0)
    reader.wait_for_node("n0", timeout=10)
    unflushed: list[int] = []
    reads = 0

    def read() -> None:
        nonlocal reads
        while any(t.is_alive() for t in threads):
            revision = reader.get("n0", ["x"]).revision
            reads += 1
            if revision > 1 and not observed.holds("n0", revision):  # r1: declared, in the snapshot
                unflushed.append(revision)

    threads = [threading.Thread(target=lane, args=(i,)) for i in range(8)]
    for t in threads:
        t.start()
    getter = threading.Thread(target=read)
    getter.start()
    for t in threads:
        t.join(60)
    getter.join(10)
    assert not failed, failed
    assert not early, f"replies before their flush: {early}"
    assert reads and not unflushed, (reads, unflushed)
    # 80 sets; one flush each would be 80: sharing makes it far fewer
    assert observed.count <= 40, observed.count
    for node in nodes:  # every node's 20 sets are on disk
        assert len(observed.durable[node]) == 20, (node, sorted(observed.durable[node]))
    store.close()
