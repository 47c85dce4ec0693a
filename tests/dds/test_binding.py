"""The binding's private API is used from one module, which refuses an unknown version."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path
from typing import Any

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


# Eight threads convert QoS at once: each asks a participant for its QoS (its entity name
# and a property) and reads the built-in participant topic (whose samples the binding
# converts too). The binding's conversion buffers are shared by every thread: without
# paramdds's lock they read each other's values or free one name twice (the process aborts).
_QOS_RACE = """
import sys, threading
import paramdds.dds._binding
from cyclonedds.builtin import BuiltinDataReader, BuiltinTopicDcpsParticipant
from cyclonedds.domain import DomainParticipant
from cyclonedds.qos import Policy, Qos

named = Qos(Policy.EntityName("racer"), Policy.Property("app", "racer", propagate=True))
dp = DomainParticipant(int(sys.argv[1]), qos=named)
other = DomainParticipant(int(sys.argv[1]), qos=named)
errors = []

def convert(i):
    try:
        reader = BuiltinDataReader(dp, BuiltinTopicDcpsParticipant)
        for _ in range(int(sys.argv[2])):
            assert dp.get_qos()[Policy.EntityName].name == "racer"
            for sample in reader.read(N=4):
                assert sample.qos[Policy.EntityName].name == "racer"
    except Exception as exc:
        errors.append(repr(exc))

threads = [threading.Thread(target=convert, args=(i,)) for i in range(8)]
for t in threads:
    t.start()
for t in threads:
    t.join()
print(len(errors), errors[:1])
sys.exit(1 if errors else 0)
"""


def test_qos_conversions_from_many_threads_do_not_race(domain_id: int, dds_env: Any) -> None:
    done = subprocess.run(
        [sys.executable, "-c", _QOS_RACE, str(domain_id), "1000"],
        env=dds_env(domain_id),
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 0, (done.returncode, done.stdout, done.stderr[-2000:])


def test_participant_keys_are_taken_without_their_qos(domain_id: int) -> None:
    from cyclonedds.builtin import BuiltinDataReader, BuiltinTopicDcpsParticipant
    from cyclonedds.core import InstanceState, ReadCondition, SampleState, ViewState
    from cyclonedds.domain import DomainParticipant

    dp = DomainParticipant(domain_id)
    other = DomainParticipant(domain_id)
    reader = BuiltinDataReader(dp, BuiltinTopicDcpsParticipant)
    new = ReadCondition(reader, SampleState.NotRead | ViewState.Any | InstanceState.Any)
    samples = _binding.take_participant_keys(reader, new, 16)
    assert {s.key for s in samples} == {dp.guid, other.guid}
    assert all(s.qos is None for s in samples)
    assert _binding.take_participant_keys(reader, new, 16) == []  # taken once
    assert reader.read(N=16) == []  # nothing kept: a participant that left leaves nothing behind
