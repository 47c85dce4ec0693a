"""Who makes a change, and through what: the :class:`Origin` every commit is stamped with.

A node records, with each change it commits, who asked for it (``who``), whether it
verified that identity (``verified``) and the channel it came through (``via``). The
server applies a request inside :func:`acting` with the origin it read from the
request (a claim, unless DDS Security authenticated the asking participant), and the
table stamps the :class:`~paramdds.core.results.ChangeSet` of its commit with
:func:`current`. A context variable rather than an argument, as for the deadline
(:mod:`.deadline`): a table subclass that overrides ``set`` keeps working, and a
change the application makes itself, on its own thread, is the process's own:
``who`` is :func:`local_identity`, verified (no claim crossed a wire), ``via`` api.
"""

from __future__ import annotations

import getpass
import os
import socket
from collections.abc import Iterator
from contextlib import contextmanager
from contextvars import ContextVar
from dataclasses import dataclass
from enum import Enum
from functools import cache

__all__ = ["Origin", "Via", "acting", "current", "local_identity", "local_origin", "parse_via", "via_text"]

AS_ENV = "PARAMDDS_AS"  # the identity a process claims when none is given (--as NAME)


class Via(str, Enum):
    """The channel a change came through."""

    CLI = "cli"  # a paramdds command
    API = "api"  # the Python API (a client, or the application's own table)
    WEB = "web"  # the web console
    ZENOH = "zenoh"  # a remote client across a Zenoh gateway
    FOXGLOVE = "foxglove"  # a Foxglove or Lichtblick Parameters panel (paramdds foxglove)
    ROS2 = "ros2"  # a ROS 2 tool, on a mirrored or an exposed node
    LOAD = "load"  # a parameter file loaded into a running node
    ASSIGN = "assign"  # a retained value (paramdds assign)
    START = "start"  # the value a node started with, from its files or spec


def via_text(via: Via | str) -> str:
    """A channel as the wire and the records write it (a Via's value, or a newer peer's text)."""
    return via.value if isinstance(via, Via) else str(via)


def parse_via(text: str) -> Via | None:
    """The channel named ``text``; None for one this version does not know (a newer peer's)."""
    return _VIAS.get(text)  # a dict, not Via(text): every set request is read through it


_VIAS = {v.value: v for v in Via}


@dataclass(frozen=True, slots=True)
class Origin:
    """Who made a change (``who``), whether the node verified it, and through what."""

    who: str
    via: Via | str  # a Via; the text of a channel this version does not know
    verified: bool = False

    @property
    def via_text(self) -> str:
        return via_text(self.via)


@cache
def _user_at_host() -> str:
    try:
        user = getpass.getuser()
    except Exception:  # no name for this uid (a container)
        user = str(os.getuid())
    return f"{user}@{socket.gethostname()}"


def local_identity() -> str:
    """The identity this process claims: ``$PARAMDDS_AS``, else ``USER@host``."""
    return os.environ.get(AS_ENV) or _user_at_host()


def local_origin(via: Via = Via.API) -> Origin:
    """A change this process makes itself: its own identity, verified (no claim crossed a wire)."""
    return Origin(local_identity(), via, verified=True)


_CURRENT: ContextVar[Origin | None] = ContextVar("paramdds_change_origin", default=None)


@contextmanager
def acting(origin: Origin) -> Iterator[None]:
    """Within this block (on this thread), every commit is stamped with ``origin``."""
    token = _CURRENT.set(origin)
    try:
        yield
    finally:
        _CURRENT.reset(token)


def current() -> Origin:
    """The origin of the change being committed on this thread (the process's own if none)."""
    origin = _CURRENT.get()
    return origin if origin is not None else local_origin()
