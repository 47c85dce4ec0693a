"""Run the examples of the documentation and compare what they print.

The convention (docs/development.md, "Examples that run") in short: an HTML comment
``<!-- example -->`` (or ``<!-- example: OPTIONS -->``) right above a fenced block
marks it as an example; the comment does not show on GitHub or on the site.

- A ``console`` block is a shell session: lines starting with ``$ `` are commands
  (a line ending in ``\\`` continues on the next, which may start with ``> ``), the
  lines after a command are what it prints, stdout and stderr together as a terminal
  shows them.
- A ``bash`` (``sh``, ``shell``) or ``python`` block is run whole; what it prints is
  the fenced block right below it (only blank lines between), or nothing if there is
  none.
- Any other block marked with ``terminal=NAME`` is more output of the command still
  running in that terminal (a ``watch``, a server).

Options: ``terminal=NAME`` (default ``main``): commands of one terminal share a bash
process, so ``$?``, variables and ``cd`` carry over; ``running``: the block's last
command keeps running (a server, a watch), the runner goes on once it has printed
what the block shows, and stops it with Ctrl-C when the page ends; ``vary=A,B``:
values that differ from run to run, replaced by a placeholder in both the expected
and the actual output before they are compared (:data:`VARY` lists them);
``env=NAME``: the block runs in another Python environment than the test's (one of
:data:`ENVIRONMENTS`; the test provides it, or skips the page from that block on);
``skip`` (with a reason after it): not run, said so on purpose.

A whole session may sit inside the comment itself (the lines after
``<!-- example: OPTIONS`` up to ``-->``): run, not shown, for set-up a reader does
not need to see. In expected output a line ``...`` stands for any number of lines.

Every page runs in a fresh temporary directory holding a link to ``examples/``,
with its own DDS domain id and this test run's discovery tag; ``paramdds`` and
``python`` are this environment's. Nothing here mocks DDS: the examples run the
real command against real servers.
"""

from __future__ import annotations

import codecs
import contextlib
import os
import re
import signal
import subprocess
import threading
import time
import uuid
from collections.abc import Callable, Iterator, Mapping
from dataclasses import dataclass, field
from pathlib import Path

MARK = re.compile(r"^<!--\s*example(?::\s*(?P<opts>[^\n]*?))?\s*(?P<close>-->)?\s*$")
FENCE = re.compile(r"^(?P<fence>```+|~~~+)\s*(?P<lang>[\w+-]*)[^\n]*$")
SHELL_LANGS = {"bash", "sh", "shell"}
SCRIPT_LANGS = SHELL_LANGS | {"python", "console"}

# Values that differ between runs, by name: each pattern's match is replaced by <name>.
VARY: dict[str, list[str]] = {
    "pid": [r'(?<="pid": )\d+', r"(?<=\bpid )\d+"],
    "host": [r'(?<="host": )"[^"]*"', r"(?<=\bon host )'[^']*'", r"(?<=\bon )\S+(?= \(pid)"],
    "library": [r"(?<!\S)/\S*/lib[\w+-]+\.so(?:\.\d+)*(?!\S)"],
    "stamp": [r'(?<="stamp": )[-0-9.e+]+'],
    "revision": [r'(?<="revision": )\d+', r"(?<=\brevision: )\d+", r"(?<=\(rev )\d+"],
    "domain": [r"(?<=\bdomain )\d+"],
    "incarnation": [r'(?<="incarnation": ")[0-9a-f]{16}', r"\b[0-9a-f]{16}(?=:\d)"],
    "seconds": [r"\b\d+(?:\.\d+)? ?(?:s|ms)\b"],
    "time": [r"\b\d{4}-\d\d-\d\dT\d\d:\d\d:\d\d(?:\.\d+)?Z"],  # ISO 8601 UTC (history)
    "who": [r"(?<=\blast change: )\S+"],  # describe's author: a server's USER@host
}

# Python environments other than the test's own that a block may ask for with env=NAME.
ENVIRONMENTS = {
    "secure": "Cyclone DDS built with DDS Security (tests/secure/conftest.py finds it)",
    "ros2": "real ROS 2 beside paramdds (rclpy; the variables of tests/ros2/conftest.py)",
    "interop": "the C and C++ programs of examples/ at build/<vendor>/, no discovery tag (tests/interop)",
}


RUNNING_GRACE = 0.3  # s a command marked `running` must go on after showing its output


class ExampleError(AssertionError):
    """An example printed something else than its page says, or did not finish."""


@dataclass
class Step:
    """One thing to type into a terminal (``script``), and what it prints."""

    script: str
    expected: str
    running: bool = False  # the command keeps running after it printed ``expected``


@dataclass
class Example:
    path: Path
    line: int  # 1-based line of the fenced block (or of the comment, when hidden)
    lang: str
    terminal: str = "main"
    running: bool = False
    vary: tuple[str, ...] = ()
    skip: str | None = None
    env: str | None = None  # another Python environment (ENVIRONMENTS), else the test's
    steps: list[Step] = field(default_factory=list)

    @property
    def where(self) -> str:
        return f"{self.path}:{self.line}"


def _options(text: str, path: Path, line: int) -> dict[str, str]:
    out: dict[str, str] = {}
    words = text.split()
    for i, word in enumerate(words):
        key, _, value = word.partition("=")
        if key == "skip":
            out["skip"] = " ".join(words[i + 1 :]) or "(no reason given)"
            break
        if key not in ("terminal", "running", "vary", "env"):
            raise ValueError(f"{path}:{line}: unknown example option {word!r}")
        if key == "vary":
            unknown = [v for v in value.split(",") if v not in VARY]
            if unknown:
                raise ValueError(f"{path}:{line}: unknown vary {unknown} (known: {sorted(VARY)})")
        if key == "env" and value not in ENVIRONMENTS:
            raise ValueError(f"{path}:{line}: unknown env {value!r} (known: {sorted(ENVIRONMENTS)})")
        out[key] = value
    return out


def _fence_at(lines: list[str], i: int) -> tuple[str, list[str], int] | None:
    """The fenced block opening at line ``i``: (language, body, index after it)."""
    m = FENCE.match(lines[i])
    if not m:
        return None
    fence = m["fence"]
    for j in range(i + 1, len(lines)):
        if lines[j].strip() == fence or (lines[j].startswith(fence) and not lines[j][len(fence) :].strip()):
            return m["lang"].lower(), lines[i + 1 : j], j + 1
    raise ValueError(f"unclosed fence at line {i + 1}")


def _next_nonblank(lines: list[str], i: int) -> int:
    while i < len(lines) and not lines[i].strip():
        i += 1
    return i


def console_steps(body: list[str]) -> list[Step]:
    """A ``$ command`` session: one step per command, with the lines it prints."""
    steps: list[Step] = []
    command: list[str] | None = None
    output: list[str] = []
    for line in body:
        if command is not None and command[-1].endswith("\\") and not output:
            command.append(line[2:] if line.startswith("> ") else line)
        elif line.startswith("$ ") or line == "$":
            if command is not None:
                steps.append(Step("\n".join(command), "\n".join(output)))
            command, output = [line[2:]], []
        elif command is None:
            raise ValueError(f"console block: output before the first command: {line!r}")
        else:
            output.append(line)
    if command is not None:
        steps.append(Step("\n".join(command), "\n".join(output)))
    return steps


def parse(path: Path, text: str | None = None) -> list[Example]:
    """The marked examples of one page, in page order."""
    lines = (path.read_text(encoding="utf-8") if text is None else text).splitlines()
    found: list[Example] = []
    i = 0
    while i < len(lines):
        m = MARK.match(lines[i].strip())
        if not m:
            block = _fence_at(lines, i)  # a mark inside a fenced block is text (as in development.md)
            i = block[2] if block is not None else i + 1
            continue
        opts = _options(m["opts"] or "", path, i + 1)
        ex = Example(
            path, i + 1, "console", opts.get("terminal", "main"), "running" in opts,
            tuple(v for v in opts.get("vary", "").split(",") if v), opts.get("skip"), opts.get("env"),
        )
        if not m["close"]:  # a hidden session inside the comment
            end = next((j for j in range(i + 1, len(lines)) if lines[j].strip() == "-->"), None)
            if end is None:
                raise ValueError(f"{path}:{i + 1}: example comment without a closing '-->' line")
            ex.steps = console_steps(lines[i + 1 : end])
            i = end + 1
        else:
            j = _next_nonblank(lines, i + 1)
            block = _fence_at(lines, j) if j < len(lines) else None
            if block is None:
                raise ValueError(f"{path}:{i + 1}: '<!-- example -->' is not followed by a fenced block")
            lang, body, i = block
            ex.line, ex.lang = j + 1, lang
            if lang == "console":
                ex.steps = console_steps(body)
            elif lang in SHELL_LANGS or lang == "python":
                expected = ""
                k = _next_nonblank(lines, i)
                following = _fence_at(lines, k) if k < len(lines) else None
                if following is not None and following[0] not in SCRIPT_LANGS:
                    expected = "\n".join(following[1])
                    i = following[2]
                ex.steps = [Step("\n".join(body), expected)]
            elif "terminal" in opts:
                ex.steps = [Step("", "\n".join(body))]
            else:
                raise ValueError(f"{path}:{j + 1}: a marked '{lang}' block needs terminal=NAME (more output)")
        if ex.running and ex.steps:
            ex.steps[-1].running = True
        found.append(ex)
    return found


def unmarked_sessions(path: Path) -> Iterator[int]:
    """Lines of fenced blocks that look like examples but carry no mark.

    A ``console`` block, or a ``bash``/``python`` block with an output block right
    below it, claims to show what happens: it must be run or skipped on purpose.
    """
    lines = path.read_text(encoding="utf-8").splitlines()
    i = 0
    while i < len(lines):
        block = _fence_at(lines, i)
        if block is None:
            i += 1
            continue
        lang, _, after = block
        prev = _next_nonblank_back(lines, i - 1)
        marked = prev >= 0 and lines[prev].strip().startswith("<!-- example")
        k = _next_nonblank(lines, after)
        output = _fence_at(lines, k) if k < len(lines) else None
        followed = output is not None and output[0] not in SCRIPT_LANGS
        if not marked and (lang == "console" or (lang in SHELL_LANGS | {"python"} and followed)):
            yield i + 1
        if marked and lang in SHELL_LANGS | {"python"} and output is not None and followed:
            after = output[2]
        i = after


def _next_nonblank_back(lines: list[str], i: int) -> int:
    while i >= 0 and not lines[i].strip():
        i -= 1
    return i


# -- comparing ---------------------------------------------------------------


# A line Cyclone DDS's C library logs itself (a timestamp, the domain id in brackets, a thread
# name): "1795501464.054213 [134] dq.builtin: Remote secure participant … not allowed". Such
# lines come from discovery timing (a peer announcing itself while a short-lived process
# closes), never from paramdds, so they are not compared.
CYCLONE_LOG_LINE = re.compile(r"^\d+\.\d+ \[\d+\] [\w.-]+: ")


def normalise(text: str, vary: tuple[str, ...]) -> str:
    """Trailing spaces, surrounding blank lines and Cyclone's own log lines dropped, the
    ``vary`` values replaced."""
    lines = text.replace("\r\n", "\n").split("\n")
    out = "\n".join(line.rstrip() for line in lines if not CYCLONE_LOG_LINE.match(line)).strip("\n")
    for name in vary:
        for pattern in VARY[name]:
            out = re.sub(pattern, f"<{name}>", out)
    return out


def matches(expected: str, actual: str, vary: tuple[str, ...]) -> bool:
    """Whether ``actual`` is what ``expected`` shows (a ``...`` line: any lines)."""
    exp, act = normalise(expected, vary), normalise(actual, vary)
    if "..." not in exp.split("\n"):
        return exp == act
    pattern = "".join(
        r"(?:[^\n]*\n)*?" if line == "..." else re.escape(line) + r"\n" for line in exp.split("\n")
    )
    return re.fullmatch(pattern, act + "\n") is not None


# -- running -----------------------------------------------------------------


class Terminal:
    """A bash process fed one step at a time; its output is read by a thread."""

    def __init__(self, name: str, cwd: Path, env: dict[str, str]) -> None:
        self.name = name
        self._sentinel = f"__paramdds_docs_{uuid.uuid4().hex}__"
        self._done = re.compile(r"\n?" + re.escape(self._sentinel) + r" (\d+)\n")
        self._proc = subprocess.Popen(
            ["bash", "--norc", "--noprofile"], cwd=cwd, env=env, stdin=subprocess.PIPE,
            stdout=subprocess.PIPE, stderr=subprocess.STDOUT, start_new_session=True,
        )
        self._out = ""  # printed since the current step was sent
        self._decoder = codecs.getincrementaldecoder("utf-8")("replace")
        self._cond = threading.Condition()
        self._reader = threading.Thread(target=self._read, daemon=True, name=f"docs-{name}")
        self._reader.start()
        self.busy: Step | None = None  # a step whose command keeps running
        self.busy_vary: tuple[str, ...] = ()  # and what varies in its output

    def _read(self) -> None:
        assert self._proc.stdout is not None
        while chunk := os.read(self._proc.stdout.fileno(), 65536):
            with self._cond:
                self._out += self._decoder.decode(chunk)
                self._cond.notify_all()
        with self._cond:
            self._cond.notify_all()

    def send(self, script: str) -> None:
        assert self._proc.stdin is not None
        # stdin of the commands is /dev/null, so none of them reads the next step's text;
        # the sentinel carries $? and restores it for the next step (`echo $?` works).
        text = (
            "{\n" + script + "\n} < /dev/null\n"
            f"__rc=$?; printf '\\n{self._sentinel} %s\\n' \"$__rc\"; (exit $__rc)\n"
        )
        with self._cond:
            self._out = ""
        self._proc.stdin.write(text.encode())
        self._proc.stdin.flush()

    def wait(self, step: Step, vary: tuple[str, ...], timeout: float, where: str) -> None:
        """Until the step's command ends (or, if it keeps running, has shown its output)."""
        deadline = time.monotonic() + timeout
        with self._cond:
            while True:
                end = self._done.search(self._out)
                if end is not None:
                    printed, self._out = self._out[: end.start()], self._out[end.end() :]
                    self.busy = None
                    if step.running:
                        raise ExampleError(
                            f"{where}: terminal {self.name!r}: the command should keep running "
                            f"but ended (status {end[1]})\n{_diff(step.expected, printed, vary)}"
                        )
                    if not matches(step.expected, printed, vary):
                        raise ExampleError(f"{where}: output differs\n{_diff(step.expected, printed, vary)}")
                    return
                if step.running and matches(step.expected, self._out, vary):
                    # A command that ends right after printing it does not keep running.
                    if not self._cond.wait_for(lambda: self._done.search(self._out), RUNNING_GRACE):
                        self.busy = step
                        return
                    continue
                left = deadline - time.monotonic()
                if left <= 0 or (self._proc.poll() is not None and not self._reader.is_alive()):
                    raise ExampleError(
                        f"{where}: terminal {self.name!r}: still not as shown after {timeout:.0f} s\n"
                        f"{_diff(step.expected, self._out, vary)}"
                    )
                self._cond.wait(min(left, 0.1))

    def close(self) -> None:
        """Ctrl-C to whatever still runs, then the shell ends; kill after a grace period."""
        if self._proc.stdin is not None:
            with contextlib.suppress(BrokenPipeError):
                self._proc.stdin.close()
        for sig, grace in ((signal.SIGINT, 5.0), (signal.SIGTERM, 3.0), (signal.SIGKILL, 3.0)):
            try:
                os.killpg(self._proc.pid, sig)
            except ProcessLookupError:
                break
            try:
                self._proc.wait(grace)
                break
            except subprocess.TimeoutExpired:
                continue
        with contextlib.suppress(ProcessLookupError):  # children left in the group (`&`)
            os.killpg(self._proc.pid, signal.SIGKILL)
        self._reader.join(2.0)
        if self._proc.stdout is not None:
            self._proc.stdout.close()


def _diff(expected: str, actual: str, vary: tuple[str, ...]) -> str:
    return f"--- expected\n{normalise(expected, vary)}\n--- printed\n{normalise(actual, vary)}\n---"


Environments = Mapping[str, Callable[[dict[str, str]], dict[str, str]]]


def run_page(
    examples: list[Example], cwd: Path, env: dict[str, str], timeout: float = 30.0,
    environments: Environments | None = None,
) -> int:
    """Runs a page's examples in order; returns how many ran. Raises ExampleError.

    ``environments`` makes, from ``env``, the environment of a block's ``env=NAME``; it
    is called at the first block that names it (it may skip the test from there on).
    """
    terminals: dict[str, Terminal] = {}
    term_env: dict[str, str | None] = {}
    made: dict[str, dict[str, str]] = {}
    ran = 0
    try:
        for n, ex in enumerate(examples):
            if ex.skip is not None:
                continue
            if ex.env is not None and ex.env not in made:
                if ex.env not in (environments or {}):
                    raise ExampleError(f"{ex.where}: this test provides no environment {ex.env!r}")
                made[ex.env] = (environments or {})[ex.env](env)
            term = terminals.get(ex.terminal)
            if term is None:
                term = terminals[ex.terminal] = Terminal(ex.terminal, cwd, made[ex.env] if ex.env else env)
                term_env[ex.terminal] = ex.env
            elif term_env[ex.terminal] != ex.env:
                raise ExampleError(
                    f"{ex.where}: terminal {ex.terminal!r} runs in env={term_env[ex.terminal]}: "
                    "every block of a terminal names the same env"
                )
            for step in ex.steps:
                if step.script:
                    if term.busy is not None:
                        raise ExampleError(
                            f"{ex.where}: terminal {ex.terminal!r} still runs the command of an "
                            "earlier block: use another terminal=NAME"
                        )
                    script = step.script
                    if ex.lang == "python":
                        file = cwd / f"example_{n}.py"
                        file.write_text(step.script + "\n", encoding="utf-8")
                        script = f"python {file.name}"
                    term.send(script)
                    term.wait(step, ex.vary, timeout, ex.where)
                    term.busy_vary = ex.vary
                else:  # more output of the command still running there
                    if term.busy is None:
                        raise ExampleError(f"{ex.where}: nothing runs in terminal {ex.terminal!r}")
                    combined = Step("", term.busy.expected + "\n" + step.expected, running=True)
                    term.wait(combined, tuple(dict.fromkeys(term.busy_vary + ex.vary)), timeout, ex.where)
            ran += 1
    finally:
        for term in terminals.values():
            term.close()
    return ran
