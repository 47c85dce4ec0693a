"""Every marked example of README.md and docs/ runs, and prints what its page shows.

One test per page (a page's examples share terminals and servers, in page order);
the runner and the marking convention are in tests/docs/examples.py and
docs/development.md. A page whose output changes fails here with both texts.
"""

from __future__ import annotations

import os
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

from paramdds.dds.participant import domain_config

from ..conftest import make_dds_env
from ..interop.conftest import build_programs, require_program
from ..ros2.conftest import require_ros2, ros_vars
from ..secure.conftest import require_secure_bin
from .examples import parse, run_page, unmarked_sessions

ROOT = Path(__file__).resolve().parents[2]
PAGES = [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]
WITH_EXAMPLES = [p for p in PAGES if any(ex.skip is None for ex in parse(p))]
# sessions of many servers and commands
LONG_PAGES = {"docs/cli.md", "docs/foxglove.md", "docs/history.md", "docs/schema.md"}


def _marked(page: Path) -> Any:
    """A page, marked slow when its examples need ROS 2, a secure or a C/C++ build, or run long."""
    needs_env = any(ex.env for ex in parse(page) if ex.skip is None)
    if needs_env or page.relative_to(ROOT).as_posix() in LONG_PAGES:
        return pytest.param(page, marks=pytest.mark.slow)
    return page


def _page_env(domain_id: int) -> dict[str, str]:
    env = make_dds_env(domain_id, PYTHONUNBUFFERED="1", COLUMNS="80", LC_ALL="C.UTF-8")
    env["PATH"] = f"{Path(sys.executable).parent}{os.pathsep}{env.get('PATH', '')}"
    return env


def _secure_env(env: dict[str, str]) -> dict[str, str]:
    """``env=secure``: the secure Cyclone environment's commands first on PATH (skips without it)."""
    return {**env, "PATH": f"{require_secure_bin()}{os.pathsep}{env['PATH']}"}


def _ros2_env(tmp_path: Path) -> Callable[[dict[str, str]], dict[str, str]]:
    """``env=ros2``: real ROS 2 beside paramdds, on a ROS 2 domain of the page's own (the
    variables of tests/ros2); skipped with the reason without the ros2 extra, failed under
    CI=true, as tests/ros2 is."""

    def make(env: dict[str, str]) -> dict[str, str]:
        require_ros2()
        return {**env, **ros_vars(tmp_path)}

    return make


def _interop_env(tmp_path: Path) -> Callable[[dict[str, str]], dict[str, str]]:
    """``env=interop``: the C and C++ programs of examples/ built (as tests/interop builds
    them, once, into its cache) at ``build/<vendor>/paramdds_peer`` of the page's directory,
    and no discovery tag (Fast DDS knows none): Cyclone's loopback settings in
    CYCLONEDDS_URI, for Cyclone C and paramdds alike. Skipped with the reason without the
    toolchains, failed under CI=true, as tests/interop is."""

    def make(env: dict[str, str]) -> dict[str, str]:
        for name, built in build_programs().items():
            program = tmp_path / "build" / name / "paramdds_peer"
            program.parent.mkdir(parents=True, exist_ok=True)
            program.symlink_to(require_program(name, built))
        with pytest.MonkeyPatch.context() as untagged:  # paramdds's loopback settings alone
            untagged.delenv("CYCLONEDDS_URI", raising=False)
            return {**env, "CYCLONEDDS_URI": domain_config(localhost=True) or ""}

    return make


@pytest.mark.timeout(180)
@pytest.mark.parametrize("page", [_marked(p) for p in WITH_EXAMPLES], ids=lambda p: str(p.relative_to(ROOT)))
def test_page_examples_print_what_the_page_shows(page: Path, domain_id: int, tmp_path: Path) -> None:
    (tmp_path / "examples").symlink_to(ROOT / "examples")
    environments = {"secure": _secure_env, "ros2": _ros2_env(tmp_path), "interop": _interop_env(tmp_path)}
    ran = run_page(parse(page), tmp_path, _page_env(domain_id), environments=environments)
    assert ran > 0


@pytest.mark.parametrize("page", PAGES, ids=lambda p: str(p.relative_to(ROOT)))
def test_every_session_shown_is_marked(page: Path) -> None:
    """A block that shows a command and its output is run, or skipped with a reason."""
    lines = list(unmarked_sessions(page))
    assert not lines, (
        f"{page.relative_to(ROOT)}: blocks at lines {lines} show commands and output but are not "
        "marked '<!-- example -->' (or '<!-- example: skip REASON -->'): see docs/development.md"
    )


def test_the_readme_and_the_cli_page_have_examples() -> None:
    """The pages a newcomer reads first are run, not only parsed."""
    assert ROOT / "README.md" in WITH_EXAMPLES
    assert ROOT / "docs" / "cli.md" in WITH_EXAMPLES
