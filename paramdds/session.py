"""A command's DDS session (a CLI verb, the web console): one participant, created on first use,
closed in order.

Cyclone and the DDS layer are imported here, when a verb first needs them, so
parsing and ``--help`` stay light. Entities are closed in reverse order of
creation (monitor and clients before the participant), which keeps exit prompt.
"""

from __future__ import annotations

import argparse
import logging
from typing import TYPE_CHECKING, Any

from .core.origin import Via

if TYPE_CHECKING:
    from .dds.assign import Assigner, ReplyCallback
    from .dds.client import ParameterClient
    from .dds.monitor import EventCallback, ParameterMonitor
    from .dds.qos import QosProfiles
    from .zenoh.completeness import Lack

log = logging.getLogger(__name__)

# verbs that stay up: their participants keep Cyclone's default announcement interval
LONG_LIVED_VERBS = frozenset(
    {"server", "demo", "client", "watch", "assign", "web", "ros2", "foxglove", "record"}
)


class Session:
    """Lazily built DDS objects for one command run; use as a context manager."""

    def __init__(self, args: argparse.Namespace, app_name: str = "paramdds-cli") -> None:
        self.args = args
        self._app_name = app_name
        self._participant: Any = None
        self._qos: QosProfiles | None = None
        self._closers: list[Any] = []
        self._zenoh: Any = None  # --zenoh: the Zenoh session the remote client and monitor share
        self._remote_monitors: list[Any] = []  # the RemoteParameterMonitors made (see missing_sites)

    @property
    def participant(self) -> Any:
        if self._participant is None:
            from .dds.participant import make_participant

            identity = None
            if getattr(self.args, "identity", None):  # secure mode (paramdds.secure)
                from .secure.identity import load_identity

                identity = load_identity(self.args.identity)
            self._participant = make_participant(
                self.args.domain,
                localhost=self.args.localhost,
                app_name=self._app_name,
                short_lived=getattr(self.args, "verb", None) not in LONG_LIVED_VERBS,
                identity=identity,
            )
        return self._participant

    @property
    def qos(self) -> QosProfiles:
        if self._qos is None:
            from .dds.qos import QosProfiles

            path = self.args.qos_file
            self._qos = QosProfiles.load(path) if path else QosProfiles.load()
        return self._qos

    @property
    def zenoh(self) -> Any:
        if self._zenoh is None:
            from .zenoh.config import remote_session

            self._zenoh = remote_session(self.args)
        return self._zenoh

    def client(self, via: Via = Via.CLI) -> ParameterClient:
        """The verb's client; its writes are recorded as ``via`` and under ``--as``."""
        as_ = getattr(self.args, "as_name", None)
        if getattr(self.args, "zenoh", None):  # every site's nodes, as SITE/NODE (paramdds.zenoh)
            from .zenoh.client import RemoteParameterClient

            remote = RemoteParameterClient(self.zenoh, timeout=self.args.timeout, as_=as_)
            self._closers.append(remote)
            return remote
        participant = self.participant  # first: Cyclone discovers the system while Python imports
        from .dds.client import ParameterClient

        # a node never seen counts as absent (exit 3) only once discovery has settled
        # (paramdds.dds.discovery); until then the call waits, up to --timeout. The presence
        # reader is made when a call needs it: a verb answered at once never receives the
        # system's retained parameter state (every server sends it to each new reader)
        client = ParameterClient(
            participant, self.qos, timeout=self.args.timeout, one_shot=True, as_=as_, via=via
        )
        self._closers.append(client)
        return client

    def monitor(
        self, nodes: list[str] | None = None, on_event: EventCallback | None = None
    ) -> ParameterMonitor:
        if getattr(self.args, "zenoh", None):
            from .zenoh.monitor import RemoteParameterMonitor, sites_from_env

            remote = RemoteParameterMonitor(
                self.zenoh, sites=sites_from_env(), nodes=nodes, on_event=on_event, timeout=self.args.timeout
            )
            self._closers.append(remote)
            self._remote_monitors.append(remote)
            return remote
        from .dds.monitor import ParameterMonitor

        monitor = ParameterMonitor(self.participant, self.qos, nodes=nodes or None, on_event=on_event)
        self._closers.append(monitor)
        return monitor

    def missing_sites(self) -> dict[str, Lack]:
        """With ``--zenoh``: the known sites the monitors made so far lack, and why
        (:mod:`paramdds.zenoh.completeness`); empty over DDS and when every site answered."""
        missing: dict[str, Lack] = {}
        for remote in self._remote_monitors:
            missing.update(remote.missing_sites())
        return missing

    def assigner(self, on_reply: ReplyCallback | None = None) -> Assigner:
        from .dds.assign import Assigner

        assigner = Assigner(
            self.participant, self.qos, on_reply=on_reply, as_=getattr(self.args, "as_name", None)
        )
        self._closers.append(assigner)
        return assigner

    def close(self) -> None:
        """Close what was opened, newest first; errors here are logged, never raised."""
        while self._closers:
            obj = self._closers.pop()
            try:
                obj.close()
            except Exception:
                log.debug("closing %r failed", obj, exc_info=True)
        if self._zenoh is not None:
            self._zenoh.close()
            self._zenoh = None
        if self._participant is not None:
            from .dds.participant import close_participant

            close_participant(self._participant)
            self._participant = None

    def __enter__(self) -> Session:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
