"""A verb run without its extra: one usage error naming the extra, what is missing and how to install it."""

from __future__ import annotations

import argparse
import importlib.util
import re
from importlib.metadata import requires
from pathlib import Path

import pytest

from paramdds.cli._extras import PACKAGES, require_extra
from paramdds.exits import UsageError


@pytest.mark.parametrize("extra", sorted(PACKAGES))
def test_the_packages_checked_are_what_the_extra_installs(extra: str) -> None:
    declared = [r for r in requires("paramdds") or [] if r.endswith(f'extra == "{extra}"')]
    names = {re.split(r"[<>=\[ ;]", r, maxsplit=1)[0].lower() for r in declared}
    assert set(PACKAGES[extra]) <= names


def _without(monkeypatch: pytest.MonkeyPatch, package: str) -> None:
    real = importlib.util.find_spec
    monkeypatch.setattr(
        importlib.util, "find_spec", lambda name, *a: None if name == package else real(name, *a)
    )


def test_the_error_names_what_is_missing_and_how_to_install_it(monkeypatch: pytest.MonkeyPatch) -> None:
    _without(monkeypatch, "uvicorn")
    with pytest.raises(UsageError) as caught:
        require_extra("'paramdds web'", "web")
    assert str(caught.value) == (
        "'paramdds web' needs the web extra (uvicorn not installed): "
        "pip install -e '.[web]' in the paramdds checkout"
    )
    require_extra("'paramdds web'", "web", ("starlette",))  # only what the caller needs is checked


@pytest.mark.parametrize(
    ("verb", "package", "args"),
    [
        ("record", "mcap", argparse.Namespace(nodes=[], output_file="x.mcap", split=None)),
        ("foxglove", "websockets", argparse.Namespace(nodes=[], port=0)),
    ],
)
def test_record_and_foxglove_stop_before_doing_anything(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path, verb: str, package: str, args: argparse.Namespace
) -> None:
    import importlib

    monkeypatch.chdir(tmp_path)
    _without(monkeypatch, package)
    module = importlib.import_module(f"paramdds.cli.verbs.{verb}")
    with pytest.raises(
        UsageError, match=rf"'paramdds {verb}' needs the foxglove extra \({package} not installed\)"
    ):
        module.run(args)
    assert list(tmp_path.iterdir()) == []  # no file begun
