"""Creating Topic entities: the one place a paramdds process does it.

Cyclone (11.0) can refuse to create a topic with ``DDS_RETCODE_BAD_PARAMETER`` when a
peer's endpoints of the same type are being discovered at that moment: creating the
topic adds the type's object to the domain's type library, where discovery may have
just entered the same type id, still unresolved, from the peer's announcement. The
refusal is rare (once in roughly 900 process starts beside running servers) and does
not repeat: the same call made again succeeds. A process start must not die of it, so
each creation is tried up to :data:`ATTEMPTS` times, on exactly that return code, a
few milliseconds apart, and each retry is logged at warning level (grep the logs for
``topic creation``). Any other failure, and the last attempt's, is raised as it is.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from typing import Any, TypeVar

from cyclonedds.core import DDSException
from cyclonedds.domain import DomainParticipant
from cyclonedds.topic import Topic

log = logging.getLogger(__name__)

T = TypeVar("T")

ATTEMPTS = 5
PAUSE = 0.02  # seconds before the second attempt; doubled for each further one


def created(make: Callable[[], T], name: str, *, sleep: Callable[[float], None] = time.sleep) -> T:
    """``make()``, tried again while it fails with ``DDS_RETCODE_BAD_PARAMETER`` (see above)."""
    pause = PAUSE
    for attempt in range(1, ATTEMPTS + 1):
        try:
            return make()
        except DDSException as e:
            if e.code != DDSException.DDS_RETCODE_BAD_PARAMETER or attempt == ATTEMPTS:
                raise
            log.warning(
                "topic creation of %s refused by Cyclone (%s): attempt %d of %d, trying again",
                name,
                e,
                attempt,
                ATTEMPTS,
            )
            sleep(pause)
            pause *= 2
    raise AssertionError("unreachable")  # pragma: no cover


def make_topic(participant: DomainParticipant, name: str, data_type: type) -> Any:
    """A ``Topic`` entity for ``name`` of ``data_type`` on ``participant``."""
    return created(lambda: Topic(participant, name, data_type), name)
