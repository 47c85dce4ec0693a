"""The binding's private API is used from one module, which refuses an unknown version."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from paramdds.dds import _binding

PACKAGE = Path(_binding.__file__).resolve().parent.parent
PRIVATE = re.compile(r"cyclonedds\.(?:\w+\.)*_\w+|\._ref\b|__idl__\.|ddspy_")


def test_no_module_but_binding_touches_private_api() -> None:
    offenders = [
        f"{path.relative_to(PACKAGE)}:{n}: {line.strip()}"
        for path in sorted(PACKAGE.rglob("*.py"))
        if path.name not in {"_binding.py", "_typeobjects.py"}
        for n, line in enumerate(path.read_text().splitlines(), 1)
        if PRIVATE.search(line)
    ]
    assert offenders == []


def test_the_installed_version_is_the_supported_one() -> None:
    version = _binding.installed_version()
    assert version is not None and version.startswith(_binding.SUPPORTED_VERSION + ".")


def test_another_version_fails_at_import_naming_both(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(_binding, "installed_version", lambda: "12.1.0")
    with pytest.raises(ImportError, match=r"cyclonedds 12\.1\.0 is installed.*cyclonedds>=11\.0,<12"):
        _binding._check_version()
    monkeypatch.setattr(_binding, "installed_version", lambda: "11.0.7")
    _binding._check_version()  # a patch release of the supported version is fine


class _Racing:
    """A reader whose matched list grows while the binding reads it, ``fails`` times."""

    def __init__(self, fails: int) -> None:
        self.fails = fails

    def get_matched_publications(self) -> list[int]:
        if self.fails:
            self.fails -= 1
            raise IndexError("invalid index")  # what the binding raises then
        return [7, 8]


def test_a_match_while_the_binding_lists_matches_is_asked_again() -> None:
    assert _binding.matched_publications(_Racing(fails=3)) == [7, 8]
    with pytest.raises(IndexError):  # a list that never settles is not hidden
        _binding.matched_publications(_Racing(fails=100))
