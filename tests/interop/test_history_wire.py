"""A node's history as a peer of another vendor asks for it: the raw wire of docs/wire.md.

A ``HistoryQuery`` in a ``GetParametersRequest``, written by a plain cyclonedds peer
(no paramdds client): records oldest first, at most ``limit`` a reply, paged with
``after_seq`` while ``history_more``; ``history_compacted`` while the range reaches
past what retention dropped; the filters; a refusal's and a delete's record.
"""

from __future__ import annotations

import itertools
from typing import Any

import pytest

from paramdds.core.history import Retention
from paramdds.core.table import ParameterTable
from paramdds.dds.server import ParameterServer
from paramdds.dds.wire import types as wire

from ..dds.helpers import DdsSession
from ..reliability.rawwire import RawPeer

pytestmark = pytest.mark.timeout(60)

_ids = itertools.count(1)


def _ask(peer: RawPeer, **query: Any) -> Any:
    names = query.pop("names", [])
    request = wire.GetParametersRequest(
        node_id="robot",
        client_id=4242,
        request_id=next(_ids),
        names=names,
        history=[wire.HistoryQuery(**query)],
    )
    return peer.first_answer(request)


def _int(v: wire.ParameterValue) -> int:
    assert v.type == 2
    return int(v.integer_value)


def test_a_foreign_asker_pages_through_a_nodes_history(domain_id: int) -> None:
    with DdsSession(domain_id) as session:
        table = ParameterTable("robot", allow_undeclared=True)
        table.declare("x", 0)
        server = ParameterServer(session.participant(), retention=Retention(max_records=6)).start()
        try:
            server.add_node(table)  # record 1: x's start value
            client = session.client(as_="ops")
            for i in range(1, 8):  # records 2..8; retention keeps 3..8
                client.set("robot", {"x": i})
            assert not client.set("robot", {"x": "text"}).results[0].successful  # record 9, refused
            client.set("robot", {"y": 1})  # record 10
            client.delete("robot", ["y"])  # record 11 (retention keeps 6..11)
            peer = RawPeer(session.participant())

            first = _ask(peer, since_revision=-1, limit=2)
            assert (first.history_kept, first.history_more, first.history_compacted) == (True, True, True)
            assert first.results == [] and first.node_id == "robot" and first.revision == table.revision
            seqs = [r.seq for r in first.history]
            assert seqs == [6, 7]
            pages = [first]
            while pages[-1].history_more:
                pages.append(_ask(peer, since_revision=-1, limit=2, after_seq=pages[-1].history[-1].seq))
            records = [r for page in pages for r in page.history]
            assert [r.seq for r in records] == [6, 7, 8, 9, 10, 11]
            assert [len(p.history) for p in pages] == [2, 2, 2] and not pages[-1].history_more
            assert [p.history_compacted for p in pages] == [True, False, False]  # after_seq past the drop

            applied = records[0]
            assert (applied.name, applied.applied, applied.who, applied.verified, applied.via) == (
                "x",
                True,
                "ops",
                False,
                "api",
            )
            assert [_int(v) for v in applied.old_value + applied.new_value] == [4, 5]
            refused = records[3]
            assert (refused.name, refused.applied, refused.code) == ("x", False, "TYPE_MISMATCH")
            assert [_int(v) for v in refused.old_value] == [7] and refused.new_value[0].string_value == "text"
            assert refused.revision == records[2].revision  # the node's revision then
            created, deleted = records[4], records[5]
            assert (created.old_value, [_int(v) for v in created.new_value]) == ([], [1])  # did not exist
            assert ([_int(v) for v in deleted.old_value], deleted.new_value) == ([1], [])  # deleted

            # filters: names, revision, who, outcome, time; a range after the drop is not compacted
            only_x = _ask(peer, since_revision=records[1].revision, names=["x"])
            assert [r.seq for r in only_x.history] == [8, 9] and not only_x.history_compacted
            assert [r.seq for r in _ask(peer, since_revision=-1, outcome=2).history] == [9]
            assert [r.seq for r in _ask(peer, since_revision=-1, outcome=1, who="o?s").history] == [
                6,
                7,
                8,
                10,
                11,
            ]
            assert _ask(peer, since_revision=-1, who="alice*").history == []
            t = records[4].stamp.sec * 1_000_000_000 + records[4].stamp.nanosec
            window = _ask(peer, since_revision=-1, since_time=t, until_time=t)
            assert [r.seq for r in window.history] == [10] and not window.history_compacted
        finally:
            server.close()
