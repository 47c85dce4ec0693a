"""A parameter server (own process) whose node stalls inside a set, at the worst moment.

Usage: ``python stalling_server.py DOMAIN``. Hosts node ``robot1`` with ``robot.speed``
(double 1.0), ``robot.mode`` (string "auto"), ``robot.stall_ms`` (integer 0) and
``extra.note`` (dynamically typed string, deletable). Its on-set callback runs after the
request reached the node and before the commit (the stage a request can wait in
longest), and there:

* stops the whole process with SIGSTOP when the set names ``robot.speed`` or
  ``extra.note`` (a stall of any length: the test sends SIGCONT once the caller has
  given up), and prints ``STOPPING`` first;
* sleeps ``robot.stall_ms`` milliseconds when the set names that parameter (a slow
  callback, for the "a success is never reported failed" trials).

Prints ``READY`` once it serves; ends on SIGTERM.
"""

from __future__ import annotations

import signal
import sys
import threading
import time

from paramdds.core.descriptors import ParameterDescriptor
from paramdds.core.results import SetVeto
from paramdds.core.table import ParameterTable
from paramdds.core.values import Parameter
from paramdds.dds.participant import close_participant, make_participant
from paramdds.dds.server import ParameterServer

STOP_ON = {"robot.speed", "extra.note"}


def on_set(params: list[Parameter]) -> SetVeto:
    names = {p.name for p in params}
    if names & STOP_ON:
        print("STOPPING", flush=True)
        # to this thread: it stops on its way out of the call (os.kill would let the kernel pick
        # another thread to start the stop, and this one ran on for milliseconds meanwhile)
        signal.pthread_kill(threading.get_ident(), signal.SIGSTOP)
        time.sleep(0.05)
    for p in params:
        if p.name == "robot.stall_ms":
            time.sleep(int(p.value.to_python()) / 1000)  # type: ignore[call-overload]
    return SetVeto(True)


def main() -> None:
    signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGTERM})  # every thread inherits the mask
    dp = make_participant(int(sys.argv[1]), localhost=True, app_name="stalling-server")
    table = ParameterTable("robot1")
    table.declare("robot.speed", 1.0)
    table.declare("robot.mode", "auto")
    table.declare("robot.stall_ms", 0)
    table.declare("extra.note", "keep", ParameterDescriptor("extra.note", dynamic_typing=True))
    table.add_on_set_callback(on_set)
    server = ParameterServer(dp)
    server.add_node(table)
    server.start()
    print("READY", flush=True)
    signal.sigwait({signal.SIGTERM})
    server.close()
    close_participant(dp)


if __name__ == "__main__":
    main()
