"""What a newcomer meets in the first hour on the command line, without DDS: hints, checks,
how ranges read."""

from __future__ import annotations

import argparse
import importlib.util
from pathlib import Path

import pytest

from paramdds.exits import UsageError

ROOT = Path(__file__).resolve().parents[2]


def test_the_web_extras_hint_is_the_command_docs_web_md_gives(monkeypatch: pytest.MonkeyPatch) -> None:
    from paramdds.cli.verbs import web

    real = importlib.util.find_spec
    monkeypatch.setattr(
        importlib.util, "find_spec", lambda name, *a: None if name in web.WEB_PACKAGES else real(name, *a)
    )
    with pytest.raises(UsageError) as caught:
        web.run(argparse.Namespace(port=None, bind="127.0.0.1:8800"))
    message = str(caught.value)
    command = message.rpartition("): ")[2].partition(" in ")[0]
    assert command.startswith("pip install ")
    assert f"{command}       # Starlette + uvicorn" in (ROOT / "docs" / "web.md").read_text()
