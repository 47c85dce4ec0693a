"""One fresh client's call, started on cue: for tests that time a call against a signal.

``python fresh_client_call.py NODE NAME {cli|api}``: imports everything, prints
``ready``, then waits for a line on stdin. On it, it creates a new participant and a
:class:`ParameterClient` (``cli``: as the CLI's one-shot verbs do, announcing every
second and creating the presence reader only when a call needs it; ``api``: the
API's defaults) and gets NAME of NODE with a 10 s timeout. Prints one JSON line:
``{"started": t, "ended": t, "code": "OK" | error code, "message": ...}`` with
``time.monotonic()`` times (one clock for every process of the machine), then exits.
"""

from __future__ import annotations

import json
import os
import sys
import time


def main() -> int:
    node, name, mode = sys.argv[1], sys.argv[2], sys.argv[3]
    from paramdds.dds.client import ParameterClient
    from paramdds.dds.participant import close_participant, make_participant
    from paramdds.errors import ParamddsError

    domain = int(os.environ["PARAMDDS_DOMAIN"])
    cli = mode == "cli"
    print("ready", flush=True)
    sys.stdin.readline()
    started = time.monotonic()
    participant = make_participant(domain, localhost=True, short_lived=cli)
    client = ParameterClient(participant, timeout=10.0, one_shot=cli)
    try:
        value = client.get_value(node, name).value
        code, message = "OK", json.dumps(value)
    except ParamddsError as exc:
        code, message = exc.code.value, str(exc)
    ended = time.monotonic()
    client.close()
    close_participant(participant)
    print(json.dumps({"started": started, "ended": ended, "code": code, "message": message}), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
