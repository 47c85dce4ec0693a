"""A process with a ``ParameterEvents`` writer that is alive but never delivers anything.

``python silent_state_writer.py``: on ``PARAMDDS_DOMAIN`` (loopback), a state writer
with a server's QoS (MANUAL_BY_TOPIC liveliness, 1 s lease) whose liveliness this
process asserts every 0.25 s, as a server's dispatch loop does, without ever writing
a sample: to a client it is a parameter server that still owes its state (a slow but
alive server). With ``--no-writer``, only the participant: a peer that is not a
parameter server (another CLI process, say). Prints ``ready`` once the writer (or
participant) exists, then runs until killed.
"""

from __future__ import annotations

import os
import sys
import time


def main() -> int:
    from cyclonedds.pub import DataWriter
    from cyclonedds.qos import Policy, Qos
    from cyclonedds.util import duration

    from paramdds.dds._binding import assert_liveliness
    from paramdds.dds.participant import make_participant
    from paramdds.dds.qos import QosProfiles
    from paramdds.dds.topics import make_topic
    from paramdds.dds.wire import types as wire

    participant = make_participant(int(os.environ["PARAMDDS_DOMAIN"]), localhost=True, app_name="silent")
    if "--no-writer" in sys.argv:
        print("ready", flush=True)
        while True:
            time.sleep(1.0)
    qos = QosProfiles.load().writer("ParameterEvents") + Qos(
        Policy.Liveliness.ManualByTopic(duration(seconds=1))
    )
    writer = DataWriter(participant, make_topic(participant, "ParameterEvents", wire.ParameterEvent), qos)
    print("ready", flush=True)
    while True:
        assert_liveliness(writer)
        time.sleep(0.25)


if __name__ == "__main__":
    sys.exit(main())
