"""The docs runner itself: how it reads marks, compares output, and fails.

Pure parsing and matching tests, and a few runs of real bash (no DDS needed) that
show a changed output, a command that should keep running and a stuck one fail.
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from .examples import ExampleError, matches, normalise, parse, run_page, unmarked_sessions

PAGE = """\
# A page

<!-- example -->
```console
$ echo one
one
$ printf 'a\\nb\\n' \\
>   | wc -l
2
```

<!-- example: terminal=srv running vary=pid
$ echo "pid $$"; sleep 30
pid 1
-->

<!-- example: vary=revision -->
```bash
echo '{"revision": 7}'
```

```json
{"revision": 12}
```

<!-- example: skip needs a robot -->
```console
$ robot-start
```

```bash
not marked, no output: a command to type
```
"""


def _page(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "page.md"
    path.write_text(text, encoding="utf-8")
    return path


def test_marks_are_read_with_their_options_and_outputs(tmp_path: Path) -> None:
    examples = parse(_page(tmp_path, PAGE))
    assert [(e.lang, e.terminal, e.running, e.vary, e.skip) for e in examples] == [
        ("console", "main", False, (), None),
        ("console", "srv", True, ("pid",), None),
        ("bash", "main", False, ("revision",), None),
        ("console", "main", False, (), "needs a robot"),
    ]
    first = examples[0].steps
    assert [(s.script, s.expected) for s in first] == [
        ("echo one", "one"), ("printf 'a\\nb\\n' \\\n  | wc -l", "2"),
    ]
    assert examples[2].steps[0].expected == '{"revision": 12}'
    assert examples[1].steps[-1].running


def test_only_unmarked_sessions_are_reported(tmp_path: Path) -> None:
    text = PAGE + "\n```console\n$ date\n```\n\n```python\nprint(1)\n```\n\n```\n1\n```\n"
    path = _page(tmp_path, text)
    lines = text.splitlines()
    assert [lines[n - 1] for n in unmarked_sessions(path)] == ["```console", "```python"]


def test_a_mark_inside_a_fenced_block_is_text(tmp_path: Path) -> None:
    text = "````markdown\n<!-- example -->\n```console\n$ false\n```\n````\n"
    assert parse(_page(tmp_path, text)) == []
    assert list(unmarked_sessions(_page(tmp_path, text))) == []


def test_unknown_options_and_dangling_marks_are_errors(tmp_path: Path) -> None:
    with pytest.raises(ValueError, match="unknown example option"):
        parse(_page(tmp_path, "<!-- example: termnal=x -->\n```console\n$ true\n```\n"))
    with pytest.raises(ValueError, match="unknown vary"):
        parse(_page(tmp_path, "<!-- example: vary=colour -->\n```console\n$ true\n```\n"))
    with pytest.raises(ValueError, match="not followed by a fenced block"):
        parse(_page(tmp_path, "<!-- example -->\ntext\n"))


def test_matching_takes_ellipsis_lines_and_named_variations_only() -> None:
    assert matches("a\n...\nz", "a\nb\nc\nz\n", ())
    assert matches("a\n...\nz", "a\nz", ())
    assert not matches("a\n...\nz", "a\nb\ny", ())
    assert not matches("robot.max_velocity = double 1.5", "robot.max_velocity = double 2.5", ())
    assert matches('{"pid": 1, "host": "vm"}', '{"pid": 4711, "host": "ci-7"}', ("pid", "host"))
    assert not matches('{"pid": 1, "host": "vm"}', '{"pid": 4711, "host": "ci-7"}', ("pid",))
    assert normalise("x  \n\n", ()) == "x"


def _env() -> dict[str, str]:
    return dict(os.environ)


def test_cyclones_own_log_lines_are_not_compared_anything_else_is() -> None:
    shown = "paramdds: error: refused"
    printed = "1795501464.054213 [134] dq.builtin: Remote secure participant 8f:1c1 not allowed\n" + shown
    assert matches(shown, printed, ())
    assert not matches(shown, "[134] dq.builtin: not a timestamped line\n" + shown, ())
    assert not matches(shown, "paramdds: warning: something\n" + shown, ())


def test_a_page_runs_and_a_changed_output_fails(tmp_path: Path) -> None:
    path = _page(tmp_path, PAGE)
    assert run_page(parse(path), tmp_path, _env(), timeout=10) == 3
    changed = _page(tmp_path, PAGE.replace("$ echo one\none", "$ echo one\ntwo"))
    with pytest.raises(ExampleError, match=r"page.md:4: output differs") as err:
        run_page(parse(changed), tmp_path, _env(), timeout=10)
    assert "--- expected\ntwo\n--- printed\none" in str(err.value)


def test_status_and_state_carry_over_within_a_terminal(tmp_path: Path) -> None:
    text = "<!-- example -->\n```console\n$ x=5; false\n$ echo $? $x\n1 5\n```\n"
    assert run_page(parse(_page(tmp_path, text)), tmp_path, _env(), timeout=10) == 1


def test_more_output_of_a_running_command_is_waited_for(tmp_path: Path) -> None:
    text = (
        "<!-- example: terminal=w running -->\n```console\n$ echo start; sleep 0.5; echo later; sleep 30\n"
        "start\n```\n\n<!-- example: terminal=w -->\n```\nlater\n```\n"
    )
    assert run_page(parse(_page(tmp_path, text)), tmp_path, _env(), timeout=10) == 2


def test_a_command_that_ends_or_hangs_against_the_page_fails(tmp_path: Path) -> None:
    ended = "<!-- example: running -->\n```console\n$ echo up\nup\n```\n"
    with pytest.raises(ExampleError, match="should keep running but ended"):
        run_page(parse(_page(tmp_path, ended)), tmp_path, _env(), timeout=5)
    stuck = "<!-- example -->\n```console\n$ sleep 30\n```\n"
    with pytest.raises(ExampleError, match="still not as shown after 1 s"):
        run_page(parse(_page(tmp_path, stuck)), tmp_path, _env(), timeout=1)
