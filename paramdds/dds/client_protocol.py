"""What carries a client's calls: the :class:`ClientTransport` protocol, and one call in flight.

:class:`~paramdds.dds.client.ParameterClient` holds one transport and runs each call's
life (:mod:`paramdds.core.call`: request ids, the deadline, resends, which failure a
call ends with); a transport sends, receives and knows presence. Two implement it:
DDS (:class:`~paramdds.dds.client_transport.DdsClientTransport`) and Zenoh
(:class:`~paramdds.zenoh.client.ZenohClientTransport`).

A call goes through a transport in this order: :meth:`~ClientTransport.canonical`
(the node's name), :meth:`~ClientTransport.start` (checked and encoded, not sent),
:meth:`~ClientTransport.route` (may it be sent?), :meth:`~ClientTransport.send`, then,
while it waits and only for a transport that ``resends``,
:meth:`~ClientTransport.newly_matched`, :meth:`~ClientTransport.discovery_mark`,
:meth:`~ClientTransport.presence` and :meth:`~ClientTransport.send` again; the
transport sets the reply (or the error to raise) on :attr:`PendingCall.future`; at
last :meth:`~ClientTransport.finish`, whatever happened.
"""

from __future__ import annotations

from concurrent.futures import Future
from typing import Any, Protocol, runtime_checkable

from ..core.call import Call, Failure, Mark, Request
from ..core.history import HistoryPage
from ..core.replies import GetReply, NodeInfo, SetReply
from ..core.results import ListResult
from ..errors import ParamddsError
from .discovery import Presence

__all__ = ["ClientTransport", "PendingCall"]


class PendingCall:
    """One call in flight: its life (:attr:`call`), what the transport sends (:attr:`kind`:
    its topic or verb, :attr:`message`), the transport's own handle for it (:attr:`via`,
    :attr:`matched`), and the future its raw reply (or the error to raise) is set on."""

    __slots__ = ("call", "future", "kind", "matched", "message", "serving_life", "via")

    def __init__(self, call: Call, kind: str, message: Any, via: Any = None, matched: int = 0) -> None:
        self.call = call
        self.kind = kind
        self.message = message
        self.via = via  # DDS: the request writer
        self.matched = matched  # DDS: the topic's match count when last looked at
        self.serving_life = 0  # DDS: the node's server life when a compare-and-set's first copy went out
        self.future: Future[Any] = Future()

    @property
    def node(self) -> str:
        return self.call.node


@runtime_checkable
class ClientTransport(Protocol):
    """What a transport does for :class:`~paramdds.dds.client.ParameterClient`.

    ``client_id`` is echoed in replies (0: the transport correlates replies itself).
    ``resends``: the transport sends a lost copy again and watches presence while a call
    waits (DDS); otherwise it bounds its one copy itself and sets the call's outcome when
    the copy ends (Zenoh), and ``grace`` is how long past a call's timeout that may take.
    """

    client_id: int
    resends: bool
    grace: float

    # -- a call ----------------------------------------------------------------------------

    def canonical(self, node: str) -> str:
        """The node's name as this transport spells it (InvalidNameError if it is none)."""
        ...

    def start(self, request: Request, call: Call) -> PendingCall:
        """Check and encode ``request`` and register the call (not sent yet). Raises the
        error of bad arguments, or UnavailableError when the node is known unreachable."""
        ...

    def route_known(self, pending: PendingCall) -> bool:
        """Whether :meth:`route` answers at once (else an event loop calls it in a thread)."""
        ...

    def route(self, pending: PendingCall) -> None:
        """Raise UnavailableError (nothing sent) when the call cannot reach its node; may
        wait a bounded time to learn the route."""
        ...

    def send(self, pending: PendingCall) -> None:
        """Send a copy of the request (noting :meth:`Call.sent`); raise if it could not go."""
        ...

    def newly_matched(self, pending: PendingCall) -> bool:
        """Whether the call's route gained a peer since the last look (a copy is then sent)."""
        ...

    def discovery_mark(self) -> Mark | None:
        """Where discovery is (see :meth:`Call.news`), or None when it is not watched yet."""
        ...

    def error(self, pending: PendingCall, failure: Failure, waited: float) -> ParamddsError:
        """The error a call ends with, in the transport's words (``waited``: seconds)."""
        ...

    def finish(self, pending: PendingCall) -> None:
        """Forget the call (answered, failed or abandoned)."""
        ...

    # -- replies: the raw reply set on a PendingCall's future, read -----------------------

    def list_result(self, reply: Any) -> ListResult: ...

    def get_reply(self, reply: Any) -> GetReply: ...

    def set_reply(self, reply: Any) -> SetReply: ...

    def history_page(self, reply: Any) -> tuple[bool, HistoryPage]:
        """Whether the node keeps history, and the page of it in ``reply``."""
        ...

    # -- presence --------------------------------------------------------------------------

    def presence(self, node: str) -> Presence:
        """ONLINE, OFFLINE, ABSENT (it is not there) or UNKNOWN (it may yet appear)."""
        ...

    def node_info(self, node: str) -> NodeInfo | None: ...

    def nodes(self) -> list[NodeInfo]: ...

    def wait_for_node(self, node: str, timeout: float) -> NodeInfo:
        """``node`` once online; UnavailableError (or CallTimeoutError) after ``timeout`` seconds."""
        ...

    def close(self) -> None:
        """Release the transport's entities; every call still waiting fails (see
        :func:`paramdds.core.call.closed_error`)."""
        ...
