"""The layout section of docs/development.md cannot drift from the tree or the floors."""

from __future__ import annotations

import configparser
import re
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
PAGE = ROOT / "docs" / "development.md"


def _section(title: str) -> str:
    text = PAGE.read_text(encoding="utf-8")
    start = text.index(f"\n{title}\n")
    end = re.compile(r"\n#{2,3} ").search(text, start + len(title) + 2)
    return text[start : end.start() if end else len(text)]


def _tree() -> list[str]:
    """The paths the layout block names (the first word of each line that starts with one)."""
    block = _section("## Layout").split("```")[1]
    return [line.split()[0].rstrip(",") for line in block.splitlines() if line and not line[0].isspace()]


def test_every_package_and_top_level_module_is_in_the_layout() -> None:
    named = set(_tree())
    package = ROOT / "paramdds"
    expected = {f"{p.parent.relative_to(ROOT)}/" for p in package.rglob("__init__.py")} - {"paramdds/"}
    expected |= {str(p.relative_to(ROOT)) for p in package.glob("*.py")}
    missing = sorted(expected - named)
    assert not missing, f"docs/development.md's layout lacks {missing}"


def test_everything_the_layout_names_exists() -> None:
    absent = [p for p in _tree() if not (ROOT / p).exists()]
    assert not absent, f"docs/development.md's layout names what does not exist: {absent}"


def test_every_floor_of_the_contracts_is_described() -> None:
    config = configparser.ConfigParser()
    config.read(ROOT / ".importlinter", encoding="utf-8")
    layers = config["importlinter:contract:floors"]["layers"]
    modules = {m for m in re.split(r"[\s:|]+", layers) if m}
    inner = config["importlinter:contract:dds-floors"]["layers"].split("\n")
    modules |= {f"paramdds.dds.{m.strip()}" for m in inner[-2:] if m.strip()}  # wire, _binding
    floors = _section("### Floors")
    undescribed = sorted(m for m in modules if f"`{m}`" not in floors)
    assert not undescribed, f"docs/development.md's floors do not describe {undescribed}"
