"""The soak bench's verdicts, pure: were the acknowledged writes kept, did a failed one
land, does a viewer show the right nodes online, how much did a process grow.

No DDS, no processes: the bench gathers the facts and these functions judge them.
"""

from __future__ import annotations

import contextlib
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

# a client's ledger: node -> parameter -> outcome class ("applied", "failed", "unknown") -> values
Ledger = Mapping[str, Mapping[str, Mapping[str, Iterable[int]]]]


@dataclass
class WriteVerdict:
    """What the nodes hold against what the clients were told."""

    acknowledged: int = 0  # parameter writes acknowledged as applied
    failed: int = 0  # reported failed (refused, UNAVAILABLE, TIMEOUT): must not have landed
    unknown: int = 0  # OUTCOME_UNKNOWN (either way is right)
    unknown_landed: int = 0  # of those, applied (as the node's history says)
    lost: list[str] = field(default_factory=list)  # "node param value": acknowledged, not applied
    landed_failed: list[str] = field(default_factory=list)  # reported failed, yet applied
    wrong_final: list[str] = field(default_factory=list)  # the value held is not the newest applied
    compacted: list[str] = field(default_factory=list)  # nodes whose history retention dropped some

    @property
    def ok(self) -> bool:
        return not (self.lost or self.landed_failed or self.wrong_final)

    def to_json(self) -> dict[str, Any]:
        return {
            "acknowledged": self.acknowledged,
            "failed": self.failed,
            "unknown": self.unknown,
            "unknown_landed": self.unknown_landed,
            "lost": self.lost,
            "failed_but_landed": self.landed_failed,
            "wrong_final": self.wrong_final,
            "history_compacted": self.compacted,
        }


def verify_writes(
    ledgers: Iterable[Ledger],
    finals: Mapping[str, Mapping[str, float]],
    applied: Mapping[str, Mapping[str, set[int]]],
    compacted: Iterable[str] = (),
) -> WriteVerdict:
    """Judge the clients' ledgers against each node's final values (``finals``: node ->
    parameter -> value) and the values its history records as applied (``applied``: node ->
    parameter -> values). Each client writes parameters no other writes, with values that
    only grow (its write count), so the value held must be the greatest applied, every
    acknowledged value must be among the applied, and no value reported failed may be. A
    node in ``compacted`` lost history to retention: its acknowledged values older than its
    oldest record are judged by the final value alone."""
    v = WriteVerdict(compacted=sorted(set(compacted)))
    for ledger in ledgers:
        for node, params in ledger.items():
            for name, outcomes in params.items():
                acked = set(outcomes.get("applied", ()))
                failed = set(outcomes.get("failed", ()))
                unknown = set(outcomes.get("unknown", ()))
                landed = applied.get(node, {}).get(name, set())
                v.acknowledged += len(acked)
                v.failed += len(failed)
                v.unknown += len(unknown)
                v.unknown_landed += len(unknown & landed)
                oldest = min(landed) if node in v.compacted and landed else 0
                v.lost += [f"{node} {name} {x}" for x in sorted(acked - landed) if x >= oldest]
                v.landed_failed += [f"{node} {name} {x}" for x in sorted(failed & landed)]
                newest = max(landed, default=0)
                held = finals.get(node, {}).get(name)
                if held is None or int(held) != newest or (acked and newest < max(acked)):
                    v.wrong_final.append(f"{node} {name}: holds {held}, newest applied {newest}")
    return v


def traced(lost: Iterable[str], acks: Iterable[Path]) -> list[str]:
    """Each lost ``node param value`` with its acknowledgement as its client wrote it down
    (``acks``: files of ``node value revision incarnation time`` lines): which server life
    said it applied it, at which revision, when: where to look in that server's history."""
    lost = list(lost)
    if not lost:
        return []
    wanted = {tuple(entry.split()[::2]) for entry in lost}  # (node, value)
    found: dict[tuple[str, ...], str] = {}
    for path in acks:
        with contextlib.suppress(FileNotFoundError), open(path) as f:
            for line in f:
                node, value, revision, incarnation, at = line.split()
                if (node, value) in wanted:
                    found[node, value] = f"r{revision} incarnation {incarnation} at {at}"
    return [f"{e}: {found.get(tuple(e.split()[::2]), 'no acknowledgement written down')}" for e in lost]


def wrong_presence(shown: Mapping[str, bool], expected: Mapping[str, bool]) -> dict[str, list[str]]:
    """Nodes a viewer shows online that are gone, and offline (or not at all) that are there."""
    return {
        "online_but_gone": sorted(n for n, up in expected.items() if not up and shown.get(n, False)),
        "offline_but_there": sorted(n for n, up in expected.items() if up and not shown.get(n, False)),
    }


def stale_values(
    shown: Mapping[str, Mapping[str, object]], finals: Mapping[str, Mapping[str, float]]
) -> list[str]:
    """``node param``: where a viewer shows another value than the node holds."""
    return [
        f"{node} {name}: shows {shown.get(node, {}).get(name)}, holds {value}"
        for node, params in sorted(finals.items())
        for name, value in sorted(params.items())
        if shown.get(node, {}).get(name) != value
    ]


def growth(before: float, after: float) -> float:
    """Growth from ``before`` to ``after`` in % (0 when ``before`` is 0)."""
    return round((after - before) / before * 100.0, 1) if before else 0.0
