"""Fixtures for the CLI tests (helpers in :mod:`._support`)."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest

from ._support import SEED_PARAMS, Proc, next_domain


@pytest.fixture
def domain() -> int:
    return next_domain()


@pytest.fixture(scope="module")
def params_file(tmp_path_factory: pytest.TempPathFactory) -> Path:
    path = tmp_path_factory.mktemp("params") / "params.yaml"
    path.write_text(SEED_PARAMS)
    return path


@pytest.fixture
def server_factory() -> Iterator[list[Proc]]:
    """Collects servers a test starts and stops them at the end."""
    procs: list[Proc] = []
    yield procs
    for proc in procs:
        if proc.popen.poll() is None:
            proc.stop()
