"""House rules of the source tree: test support lives under ``tests/``, never in the
benchmarks; every Topic entity is created through ``paramdds.dds.topics``."""

from __future__ import annotations

import ast
from pathlib import Path

TESTS = Path(__file__).resolve().parent
BENCH = "paramdds.bench"
ROOT = TESTS.parent
# the two modules that may build a cyclonedds Topic: make_topic (with its retry) and the
# content-filtered topic, itself created through the same retry
TOPIC_MAKERS = {"paramdds/dds/topics.py", "paramdds/dds/filters.py"}


def bench_imports(source: str) -> list[int]:
    """The lines of ``source`` that import ``paramdds.bench`` or anything in it, however spelled."""
    lines = []
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            names = [node.module, *(f"{node.module}.{a.name}" for a in node.names)]
        else:
            continue
        if any(n == BENCH or n.startswith(BENCH + ".") for n in names):
            lines.append(node.lineno)
    return lines


def test_no_test_imports_the_benchmarks() -> None:
    # a test runs a benchmark as a user does (`paramdds bench ... --quick`); what it needs
    # besides lives in tests/support. Only the benchmarks' own tests (tests/bench) import
    # them, to check a bench's pure verdicts (the soak's) apart from a run
    found = [
        f"{path.relative_to(TESTS.parent)}:{line}"
        for path in sorted(TESTS.rglob("*.py"))
        if TESTS / "bench" not in path.parents
        for line in bench_imports(path.read_text())
    ]
    assert found == []


def test_the_check_sees_every_spelling() -> None:
    spellings = [
        "import paramdds.bench",
        "import paramdds.bench.worker as w",
        "from paramdds.bench.ros2 import find_realworld",
        "from paramdds import bench",
        "def f():\n    from paramdds.bench import ros2\n",
    ]
    assert [bench_imports(s) for s in spellings] == [[1], [1], [1], [1], [2]]
    assert bench_imports("import paramdds.benchmarks\nfrom paramdds import cli\nx = 'paramdds.bench'") == []


def test_every_topic_is_created_through_make_topic() -> None:
    # Cyclone now and then refuses a topic with BAD_PARAMETER while discovery enters the same
    # type (paramdds/dds/topics.py); make_topic tries again, a bare Topic(...) dies of it, as
    # a test's helper process did in CI. Scripts embedded in tests are text, so this reads text
    found = [
        f"{path.relative_to(ROOT)}:{number}"
        for tree in ("paramdds", "tests", "examples")
        for path in sorted((ROOT / tree).rglob("*.py"))
        if str(path.relative_to(ROOT)) not in TOPIC_MAKERS and path != Path(__file__).resolve()
        for number, line in enumerate(path.read_text().splitlines(), 1)
        if "from cyclonedds.topic import" in line or "import cyclonedds.topic" in line
    ]
    assert found == []
