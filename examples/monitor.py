"""A central monitor: one reader on ParameterEvents prints every change of every node.

Late joiners get the whole current state first (added events), then live changes
and node presence (online/offline), however many nodes there are.

    PARAMDDS_LOCALHOST=1 python examples/monitor.py
"""

from __future__ import annotations

import os
import time

from paramdds.dds.monitor import EventKind, MonitorEvent, ParameterMonitor
from paramdds.dds.participant import localhost_from_env, make_participant


def show(event: MonitorEvent) -> None:
    if event.event is EventKind.SYNCED:
        print("--- initial state received; live changes follow ---", flush=True)
    elif event.event in (EventKind.ONLINE, EventKind.OFFLINE):
        print(f"[{event.node}] {event.event.value}", flush=True)
    else:
        value = "" if event.value is None else f" = {event.value.show()}"
        print(f"[{event.node}] rev {event.revision} {event.event.value} {event.name}{value}", flush=True)


def main() -> None:
    domain = int(os.environ.get("PARAMDDS_DOMAIN", "1"))
    participant = make_participant(domain, localhost=localhost_from_env(), app_name="example-monitor")
    with ParameterMonitor(participant, on_event=show) as monitor:
        try:
            while True:
                time.sleep(5.0)
                states = monitor.snapshot()
                online = sum(1 for s in states.values() if s.online)
                print(f"... {online} of {len(states)} nodes online", flush=True)
        except KeyboardInterrupt:
            pass


if __name__ == "__main__":
    main()
