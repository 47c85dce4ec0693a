"""Helpers for the web console tests: a real ``paramdds web`` process on loopback.

Servers and the console run as ``paramdds`` subprocesses (tests/cli/_support.py),
each test module on a DDS domain of its own; nothing mocks DDS or HTTP.
"""

from __future__ import annotations

import re
from pathlib import Path

from ..cli._support import ROOT, Proc

CONSOLE_PARAMS = ROOT / "examples" / "console_params.yaml"
_URL = re.compile(r"http://[^/ ]+/")


class Console:
    """``paramdds web --bind 127.0.0.1:0 ARGS`` and the URL it printed."""

    def __init__(self, domain: int, *args: str) -> None:
        self.proc = Proc(domain, ["web", "--bind", "127.0.0.1:0", "--timeout", "5", *args])
        line = self.proc.wait_for("[WEB] Console on", timeout=30)
        match = _URL.search(line)
        assert match, line
        self.url = match.group(0)

    def stop(self) -> None:
        if self.proc.popen.poll() is None:
            self.proc.stop()


def write_token(tmp: Path, token: str) -> Path:
    path = tmp / "token"
    path.write_text(token + "\n")
    return path
