"""What a server needs from a table it hosts: the :class:`HostedTable` protocol.

A server (:class:`paramdds.dds.server.ParameterServer`, its node workers and its state
publication) serves a node through these members only. A
:class:`~paramdds.core.table.ParameterTable` is a HostedTable as it is: the parameters
live in it and its sets commit in it. Any other class with these members can be hosted
too; the ROS 2 bridge hosts its mirrored nodes that way (:mod:`paramdds.ros2.mirror`):
each holds a plain ParameterTable for what it knows of the node and forwards sets to the
node's own process.

The rules a hosted table keeps:

* **One node.** ``node_id`` never changes; ``revision`` counts its commits and is the
  revision of the last one.
* **Every change is told.** Each commit, whatever made it (a request the server passed
  to ``set`` or ``set_atomically``, the application, another process), reaches the
  change listeners as one :class:`~paramdds.core.results.ChangeSet`, in revision order:
  the server persists and publishes what the listeners get, and nothing else.
* **Reads never change anything**, and a refusal is raised as a
  :class:`~paramdds.errors.ParamddsError` (its code goes into the reply).
* **``try_locked``** holds the table's lock and yields True when it is free right now,
  else yields False at once: the server's dispatch thread answers a read inline only
  when it is True (it must never wait on a callback another thread is running).
* **``forwards_writes``** is True for a table whose sets wait on another process: the
  server answers its reads at once even while a set is out (they never wait for its
  writes), and a set that outlasts the liveliness lease marks the node ``stale``, not
  offline.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from contextlib import AbstractContextManager
from typing import Protocol

from .descriptors import ParameterDescriptor
from .results import ChangeSet, GetResult, ListResult, SetOutcome
from .values import Parameter, ParameterValue

__all__ = ["HostedTable"]

# Aliases: inside HostedTable, ``list`` names a method.
_Names = list[str]
_Results = list[GetResult]
_Snapshot = Sequence[tuple[str, ParameterValue, ParameterDescriptor]]


class HostedTable(Protocol):
    """The parameters of one node as a server serves them (see the module docstring)."""

    @property
    def node_id(self) -> str: ...

    @property
    def revision(self) -> int: ...

    @property
    def forwards_writes(self) -> bool: ...

    # -- reading ----------------------------------------------------------------------

    def __len__(self) -> int:
        """How many parameters the node has (its presence sample's count)."""
        ...

    def has(self, name: str) -> bool: ...

    def names(self) -> _Names:
        """Every name the node has, sorted."""
        ...

    def snapshot(self) -> _Snapshot:
        """``(name, value, descriptor)`` for every parameter, sorted by name."""
        ...

    def get_many(self, names: Sequence[str], *, with_descriptors: bool = False) -> _Results:
        """One result per name, in order: a value, or a NOT_FOUND / INVALID_NAME status."""
        ...

    def list(self, prefixes: Sequence[str] = (), depth: int = 0) -> ListResult:
        """Names and prefixes by rclcpp's algorithm (see :mod:`paramdds.core.listing`)."""
        ...

    def try_locked(self) -> AbstractContextManager[bool]: ...

    # -- writing ------------------------------------------------------------------------

    def set(self, params: Sequence[Parameter], *, expected_revision: int | None = None) -> SetOutcome:
        """Set each parameter on its own; one result per parameter, in request order.

        Called inside :func:`paramdds.core.deadline.applying`: past the request's deadline
        it raises EXPIRED and changes nothing."""
        ...

    def set_atomically(
        self, params: Sequence[Parameter], *, expected_revision: int | None = None
    ) -> SetOutcome:
        """Set all the parameters or none of them (the deadline: as :meth:`set`)."""
        ...

    # -- watching -----------------------------------------------------------------------

    def add_change_listener(self, fn: Callable[[ChangeSet], None]) -> object:
        """``fn`` gets every committed ChangeSet, in revision order; returns a handle."""
        ...

    def remove_change_listener(self, handle: object) -> None: ...
