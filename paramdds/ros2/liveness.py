"""Which ROS 2 processes of mirrored nodes answer: one small service call per process.

ROS 2 says nothing about a process that stopped running (SIGSTOP, a debugger, a swap
storm) until Fast DDS's participant lease runs out (20 s by default). So the bridge asks:
every :data:`PROBE_EVERY` seconds it calls ``get_parameter_types`` with no names on one
mirrored node of each process (the cheapest parameter service: an empty answer), and a
call unanswered for :data:`STALE_AFTER` seconds shows the process stalled, until it
answers. A stalled process is asked every :data:`PROBE_STALLED` seconds, and its answer
wakes the bridge's loop (``on_answer``): it is shown running again as soon as it answers.
A process is a DDS participant (the first 12 bytes of its writers' GIDs, the GUID
prefix): an rclpy process stopped, or starved, answers for none of its nodes.

One call per process, not per node, and one client per process in the bridge, made by the
participant its node is mirrored through (the bridge's own, or one that found the process
again after a stall past the lease: the bridge's own may not see it any more). What a
call costs the process grows with its nodes all the same (rclpy's executor rebuilds its
wait set from every node's entities on each wake-up): docs/ros2.md has the figures.
"""

from __future__ import annotations

import logging
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

from .rosside import RosSide

log = logging.getLogger(__name__)

PROBE_EVERY = 1.0  # seconds between two probes of one process
PROBE_STALLED = 0.25  # seconds between two probes of a process shown stalled
STALE_AFTER = 1.0  # seconds a probe may go unanswered before its process shows stalled
RESEND_AFTER = 5.0  # seconds after which an unanswered probe is no longer waited for
PREFIX = 12  # bytes of a GID that name its participant (the RTPS GUID prefix)


def process_of(writers: frozenset[bytes]) -> bytes | None:
    """The participant of a node, from its ``/parameter_events`` writers (None: none known)."""
    return min(writers)[:PREFIX] if writers else None


@dataclass
class _Probe:
    """The probe of one process: the node it asks, the client, the calls out (oldest first)."""

    fqn: str
    side: RosSide  # the participant that made the client
    client: Any
    out: list[tuple[float, Any]] = field(default_factory=list)  # (sent at, future)
    next_at: float = 0.0
    stalled: bool = False
    since: float = 0.0  # while stalled: when its oldest call unanswered was sent


class Liveness:
    """The probes of every process of mirrored nodes, run by :meth:`update` from the bridge's
    loop (the only thread that touches them: a reply is seen by polling its future).

    A probe is sent every :data:`PROBE_EVERY` seconds whether or not the one before was
    answered: a request that reached a stopped process is not always answered when it
    resumes (seen: not until the 5 s after which it is dropped), a new one is at once. Any
    answer shows the process answering; it shows stalled once a call out, sent after the
    last one answered (or out when that answer was seen: timed from then), is
    :data:`STALE_AFTER` old, until one is answered."""

    def __init__(self, on_answer: Callable[[], None] | None = None) -> None:
        self._probes: dict[bytes, _Probe] = {}
        self._on_answer = on_answer  # called (on the executor's thread) when a stalled process answers
        self.sent = 0  # probes sent (for the figures)

    def update(self, processes: Mapping[bytes, Mapping[str, RosSide]], now: float) -> dict[bytes, float]:
        """Probe each process once due (its nodes: fqn -> the participant each is mirrored
        through); the processes stalled now, with when each stopped answering (its oldest call
        unanswered was sent then)."""
        for prefix in self._probes.keys() - processes.keys():
            self._drop(prefix)
        stalled: dict[bytes, float] = {}
        for prefix, nodes in processes.items():
            probe = self._probes.get(prefix)
            if probe is None or nodes.get(probe.fqn) is not probe.side:
                if probe is not None:
                    self._drop(prefix)
                fqn = min(nodes)
                probe = self._probes[prefix] = _Probe(fqn, nodes[fqn], self._client(nodes[fqn], fqn))
            self._collect(probe, now)
            if now >= probe.next_at:
                self._send(probe, now)
            if probe.stalled:
                stalled[prefix] = probe.since
        return stalled

    def _collect(self, probe: _Probe, now: float) -> None:
        """Take the answers in; drop the calls they supersede or too old to wait for."""
        answered = max((t for t, f in probe.out if f.done() and f.exception() is None), default=None)
        if answered is not None:
            if probe.stalled:
                log.warning("the ROS 2 process of %s answers again", probe.fqn)
            probe.stalled = False
        keep: list[tuple[float, Any]] = []
        for t, f in probe.out:
            if f.done() or (answered is not None and t <= answered) or now - t >= RESEND_AFTER:
                if not f.done():
                    probe.client.remove_pending_request(f)
            else:
                keep.append((t, f))
        if answered is not None:
            # it answers now: a call still out is late from now on, not from when it was sent
            # (those sent while it was stopped would show it stalled again at its first answer)
            keep = [(now, f) for _, f in keep]
        probe.out = keep
        late = now - keep[0][0] if keep else 0.0
        if late >= STALE_AFTER and not probe.stalled:
            probe.stalled, probe.since = True, keep[0][0]
            log.warning(
                "the ROS 2 process of %s has not answered for %.1f s: its nodes show stale", probe.fqn, late
            )

    def excuse(self, now: float) -> None:
        """The bridge itself did not run for a while (stopped, starved): the probes out were
        not late, their answers may wait unread. Count them from now."""
        for probe in self._probes.values():
            probe.out = [(now, f) for _, f in probe.out]

    @staticmethod
    def _client(side: RosSide, fqn: str) -> Any:
        from rcl_interfaces import srv

        return side.client(srv.GetParameterTypes, f"{fqn}/get_parameter_types")

    def _send(self, probe: _Probe, now: float) -> None:
        from rcl_interfaces import srv

        probe.next_at = now + (PROBE_STALLED if probe.stalled else PROBE_EVERY)
        if not probe.client.service_is_ready():  # not matched (yet): a call would say nothing
            return
        future = probe.client.call_async(srv.GetParameterTypes.Request(names=[]))
        if probe.stalled and self._on_answer is not None:
            wake = self._on_answer
            future.add_done_callback(lambda _f: wake())
        probe.out.append((now, future))
        self.sent += 1

    def _drop(self, prefix: bytes) -> None:
        probe = self._probes.pop(prefix)
        try:
            probe.side.destroy_client(probe.client)
        except Exception:  # its participant closed already
            log.debug("destroying the probe client of %s failed", probe.fqn, exc_info=True)

    def close(self) -> None:
        for prefix in list(self._probes):
            self._drop(prefix)
