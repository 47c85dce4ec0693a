"""Topic creation's one home: retried on exactly Cyclone's rare BAD_PARAMETER refusal."""

from __future__ import annotations

import logging

import pytest
from cyclonedds.core import DDSException
from cyclonedds.domain import DomainParticipant

from paramdds.dds import topics
from paramdds.dds.topics import ATTEMPTS, created, make_topic
from paramdds.dds.wire import types as wire


class Flaky:
    """A factory that fails ``failures`` times with ``code``, then returns ``"topic"``."""

    def __init__(self, failures: int, code: int = DDSException.DDS_RETCODE_BAD_PARAMETER) -> None:
        self.failures = failures
        self.code = code
        self.calls = 0

    def __call__(self) -> str:
        self.calls += 1
        if self.calls <= self.failures:
            raise DDSException(self.code, "upon initialisation of a cyclonedds.topic.Topic")
        return "topic"


def test_a_refusal_that_does_not_repeat_is_retried_and_logged(caplog: pytest.LogCaptureFixture) -> None:
    pauses: list[float] = []
    make = Flaky(failures=2)
    with caplog.at_level(logging.WARNING, logger=topics.__name__):
        assert created(make, "ParameterEvents", sleep=pauses.append) == "topic"
    assert make.calls == 3
    assert pauses == [0.02, 0.04]
    assert [r.getMessage().split(" (")[0] for r in caplog.records] == [
        "topic creation of ParameterEvents refused by Cyclone"
    ] * 2


def test_any_other_failure_is_raised_at_once() -> None:
    pauses: list[float] = []
    make = Flaky(failures=1, code=DDSException.DDS_RETCODE_PRECONDITION_NOT_MET)
    with pytest.raises(DDSException) as caught:
        created(make, "ParameterEvents", sleep=pauses.append)
    assert caught.value.code == DDSException.DDS_RETCODE_PRECONDITION_NOT_MET
    assert (make.calls, pauses) == (1, [])


def test_a_refusal_that_persists_is_raised_after_the_last_attempt() -> None:
    pauses: list[float] = []
    make = Flaky(failures=ATTEMPTS)
    with pytest.raises(DDSException) as caught:
        created(make, "ParameterEvents", sleep=pauses.append)
    assert caught.value.code == DDSException.DDS_RETCODE_BAD_PARAMETER
    assert make.calls == ATTEMPTS
    assert len(pauses) == ATTEMPTS - 1


def test_make_topic_creates_the_named_topic_on_a_real_participant(domain_id: int) -> None:
    made = make_topic(DomainParticipant(domain_id), "ParameterEvents", wire.ParameterEvent)
    assert (made.get_name(), made.get_type_name()) == ("ParameterEvents", "paramdds::ParameterEvent")
