"""The docs runner's ``env=NAME`` (a block in another Python environment) and ``vary=library``.

Real bash, no DDS: an environment here is only a changed variable, which is what the
docs test's ``env=secure`` changes too (PATH).
"""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from .examples import ExampleError, matches, parse, run_page

PAGE = """\
<!-- example -->
```console
$ echo "${WHICH:-plain}" > before
$ echo "${WHICH:-plain}"
plain
```

<!-- example: env=secure terminal=s -->
```console
$ cat before; echo "$WHICH"
plain
secure
```

<!-- example: env=secure terminal=s -->
```console
$ echo again "$WHICH"
again secure
```

<!-- example -->
```console
$ echo "${WHICH:-plain}"
plain
```
"""


def _page(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "page.md"
    path.write_text(text, encoding="utf-8")
    return path


def test_a_block_runs_in_the_environment_it_names_and_the_others_do_not(tmp_path: Path) -> None:
    made: list[str] = []

    def secure(env: dict[str, str]) -> dict[str, str]:
        made.append(env["MARK"])
        return {**env, "WHICH": "secure"}

    env = {**os.environ, "MARK": "page"}
    env.pop("WHICH", None)
    examples = parse(_page(tmp_path, PAGE))
    assert [e.env for e in examples] == [None, "secure", "secure", None]
    assert run_page(examples, tmp_path, env, timeout=10, environments={"secure": secure}) == 4
    assert made == ["page"]  # made once, from the page's environment


def test_a_missing_environment_stops_the_page_at_its_first_block(tmp_path: Path) -> None:
    class Missing(Exception):
        pass

    def missing(env: dict[str, str]) -> dict[str, str]:
        assert (tmp_path / "before").read_text() == "plain\n"  # the blocks above it ran
        raise Missing  # the docs test skips here (or fails under CI=true)

    examples = parse(_page(tmp_path, PAGE))
    env = {k: v for k, v in os.environ.items() if k != "WHICH"}
    with pytest.raises(Missing):
        run_page(examples, tmp_path, env, timeout=10, environments={"secure": missing})
    with pytest.raises(ExampleError, match=r"page.md:\d+: this test provides no environment 'secure'"):
        run_page(examples, tmp_path, env, timeout=10)


def test_a_terminal_keeps_one_environment_and_names_are_checked(tmp_path: Path) -> None:
    mixed = PAGE.replace("<!-- example: env=secure terminal=s -->\n```console\n$ echo again",
                         "<!-- example: terminal=s -->\n```console\n$ echo again")
    with pytest.raises(ExampleError, match="terminal 's' runs in env=secure"):
        run_page(parse(_page(tmp_path, mixed)), tmp_path, dict(os.environ), timeout=10,
                 environments={"secure": lambda env: {**env, "WHICH": "secure"}})
    with pytest.raises(ValueError, match="unknown env 'ros'"):
        parse(_page(tmp_path, "<!-- example: env=ros -->\n```console\n$ true\n```\n"))


def test_a_library_path_varies_and_nothing_else_around_it() -> None:
    shown = "error: /home/me/.venv/lib/cyclonedds/../cyclonedds.libs/libddsc-ad12c33a.so.11.0.1 has none"
    printed = "error: /ci/.venv/lib/python3.12/site-packages/cyclonedds.libs/libddsc-9f.so.11.0.1 has none"
    assert matches(shown, printed, ("library",))
    assert not matches(shown, printed, ())
    assert not matches(shown, printed.replace("has none", "has it"), ("library",))
    assert not matches("error: libddsc.so has none", "error: /x/libddsc.so has none", ("library",))
