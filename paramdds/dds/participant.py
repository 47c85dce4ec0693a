"""Creating the one DomainParticipant a paramdds process uses.

Configuration layers, later ones overriding earlier ones:

0. Always (:data:`ROS_COEXISTENCE_XML`, :func:`participant_config`): Cyclone ignores
   the XTypes type information in Fast DDS's discovery data, so that a paramdds process never disturbs a ROS 2
   graph (rmw_fastrtps) on its domain id. Cyclone reads every type lookup request
   and answers each, also those Fast DDS addresses to another participant, with the
   type objects it holds; Fast DDS takes the first answer to its request from anyone,
   and an answer holding some of a ROS type's objects but not all (Cyclone learns
   them from the replies Fast DDS participants send each other) leaves the remote
   endpoint unmatched for good: a ROS 2 service never becomes available. Ignoring
   that type information, Cyclone never holds a ROS type, its answers are empty, and
   Fast DDS then matches the endpoint by type name, as without type lookup. Fast DDS
   peers of paramdds's own topics are matched by type name too. ``CYCLONEDDS_URI``
   may set the option again (empty: take Fast DDS's type information into account).
   Not part of :func:`domain_config`, which other programs may be given (a Cyclone
   older than 11 refuses the option).
1. Cyclone's own defaults and ``CYCLONEDDS_URI`` (the user's configuration).
2. With ``localhost=True`` (or ``PARAMDDS_LOCALHOST=1``, read by the CLI through
   :func:`localhost_from_env`): loopback only and unicast only. Traffic stays on
   127.0.0.1 and nothing depends on multicast; discovery goes to the 127.0.0.1
   peer on the ports of participant indices ``0..MAX_PARTICIPANT_INDEX``, so up
   to 120 participants of one domain meet on one host. Measured here: a new
   participant discovers an existing one in ~3 ms, and 40 existing ones in
   under 100 ms.
3. With ``topic_discovery=True``: Cyclone's topic discovery endpoints, so the
   ``DCPSTopic`` builtin topic is filled (it stays empty otherwise).

4. With ``short_lived=True`` (the one-shot CLI verbs): the participant announces
   itself every :data:`SHORT_LIVED_SPDP_INTERVAL` instead of Cyclone's default
   (lease minus 2 s: 8 s). A peer answers only a participant it has not met, so
   when a one-shot process's first announcement is lost on a lossy link, the
   next one is what introduces it; with 8 s between them a ``get`` with
   ``--timeout 5`` would fail. One second keeps Cyclone's own behaviour intact
   (an interval under 1 s would also stop the four directed answers a participant
   gives newcomers) and costs the network one small packet per peer address per
   second, for a process that lives a few seconds. Long-lived processes (servers,
   monitors) keep the default, so a large system is not flooded.
   Its writers also do not linger (``WriterLingerDuration`` 0 instead of 1 s):
   deleting a reliable writer otherwise waits until every matched reader has
   acknowledged everything, and a one-shot verb exits only once its reply is in,
   so the readers left are the other servers' request readers, which drop the
   request anyway. With ten busy server processes that wait was 100 to 190 ms of a
   ``paramdds get``.

A :class:`cyclonedds.domain.Domain` is created with the combined configuration.
Deleting a ``Domain`` deletes every participant in it, so the Domain is kept
alive by the participants (their ``domain``) and shared by all participants
of that domain id in this process; Cyclone allows one configuration per domain
id per process.

Every participant reports peers whose type or QoS does not match ours
(:mod:`.peers`): a warning per peer endpoint, and :func:`peer_mismatches`.

The participant carries ``EntityName`` = ``app_name`` and the ``__ProcessName``
property (propagated), which ``cyclonedds ps`` shows next to the hostname and
pid that Cyclone adds itself (``__Hostname``, ``__Pid``).
"""

from __future__ import annotations

import logging
import os
import re
import threading
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from cyclonedds.domain import Domain, DomainParticipant

    from .peers import PeerMismatch, PeerWatch
    from .transport import Grants, Participant

__all__ = [
    "CERTIFICATE_PROPERTY",
    "LOCALHOST_ENV",
    "MAX_DOMAIN_ID",
    "MAX_PARTICIPANT_INDEX",
    "ROS_COEXISTENCE_XML",
    "SHORT_LIVED_SPDP_INTERVAL",
    "close_participant",
    "domain_config",
    "localhost_from_env",
    "make_participant",
    "participant_config",
    "peer_mismatches",
    "poll_peers",
]

LOCALHOST_ENV = "PARAMDDS_LOCALHOST"
# secure mode: the participant's identity certificate (PEM), announced in discovery so a server
# can tell whose request it serves (paramdds.secure.authenticated checks it against the GUID)
CERTIFICATE_PROPERTY = "paramdds.identity_certificate"
FAST_DDS_VENDOR = "1.15"  # eProsima's RTPS vendor id (rmw_fastrtps, the default ROS 2 middleware)
log = logging.getLogger(__name__)

ROS_COEXISTENCE_XML = (
    '<CycloneDDS><Domain id="any"><Compatibility>'
    f"<IgnoreTypeInformation>{FAST_DDS_VENDOR}</IgnoreTypeInformation>"
    "</Compatibility></Domain></CycloneDDS>"
)
MAX_DOMAIN_ID = 232  # Cyclone's default port mapping fits domain ids 0..232
# Unicast discovery ports are 7400 + 250*domain + 10 + 2*index (+1): indices up
# to 119 stay inside the domain's own block of 250 ports, so parallel test runs
# on neighbouring domain ids never collide.
MAX_PARTICIPANT_INDEX = 119

_LOOPBACK_INTERFACE = '<Interfaces><NetworkInterface address="127.0.0.1"/></Interfaces>'
_LOCALHOST_XML = (
    "<General>"
    f"{_LOOPBACK_INTERFACE}"
    "<AllowMulticast>false</AllowMulticast>"
    "</General>"
    "<Discovery>"
    "<ParticipantIndex>auto</ParticipantIndex>"
    f"<MaxAutoParticipantIndex>{MAX_PARTICIPANT_INDEX}</MaxAutoParticipantIndex>"
    '<Peers><Peer address="127.0.0.1"/></Peers>'
    "</Discovery>"
)
SHORT_LIVED_SPDP_INTERVAL = "1s"
_SHORT_LIVED_XML = (
    f"<Discovery><SPDPInterval>{SHORT_LIVED_SPDP_INTERVAL}</SPDPInterval></Discovery>"
    "<Internal><WriterLingerDuration>0s</WriterLingerDuration></Internal>"
)
_TOPIC_DISCOVERY_XML = (
    "<Discovery><EnableTopicDiscoveryEndpoints>true</EnableTopicDiscoveryEndpoints></Discovery>"
)

_lock = threading.Lock()
# domain id -> (configuration, Domain); weak, so a Domain goes when its last participant does
@dataclass
class _Held:
    """A Domain this module made, with the configuration it was made with and how many open
    participants use it: deleted with the last one (Cyclone keeps a Domain it was given a
    configuration for until it is deleted, and refuses to make that domain id again)."""

    config: str
    domain: Domain
    users: int = 0


_domains: dict[int, _Held] = {}


def localhost_from_env(environ: dict[str, str] | None = None) -> bool:
    """True when ``PARAMDDS_LOCALHOST`` is set to 1/true/yes/on (case-insensitive)."""
    env = os.environ if environ is None else environ
    return env.get(LOCALHOST_ENV, "").strip().lower() in {"1", "true", "yes", "on"}


def domain_config(
    *, localhost: bool = False, topic_discovery: bool = False, short_lived: bool = False, security: str = ""
) -> str | None:
    """The Cyclone configuration string for these options, or None for Cyclone's normal one.

    The user's ``CYCLONEDDS_URI`` comes first, so our settings refine it rather
    than replace it.
    """
    user = os.environ.get("CYCLONEDDS_URI", "").strip()
    parts = []
    if localhost:
        # a user configuration that already selects loopback keeps its selection (Cyclone
        # refuses one interface selected twice); ours adds unicast discovery to it
        loopback_already = _selects_loopback(user)
        parts.append(_LOCALHOST_XML.replace(_LOOPBACK_INTERFACE, "") if loopback_already else _LOCALHOST_XML)
    if topic_discovery:
        parts.append(_TOPIC_DISCOVERY_XML)
    if short_lived:
        parts.append(_SHORT_LIVED_XML)
    if security:  # secure mode: a <Security> element (paramdds.secure.identity)
        parts.append(security)
    if not parts:
        return None
    ours = '<CycloneDDS><Domain id="any">' + "".join(parts) + "</Domain></CycloneDDS>"
    return f"{user},{ours}" if user else ours


def participant_config(
    *, localhost: bool = False, topic_discovery: bool = False, short_lived: bool = False, security: str = ""
) -> str:
    """The whole configuration of a paramdds participant's domain: :data:`ROS_COEXISTENCE_XML`
    first (the user's ``CYCLONEDDS_URI`` may set it again), then :func:`domain_config`."""
    rest = domain_config(
        localhost=localhost, topic_discovery=topic_discovery, short_lived=short_lived, security=security
    ) or os.environ.get("CYCLONEDDS_URI", "").strip()
    return f"{ROS_COEXISTENCE_XML},{rest}" if rest else ROS_COEXISTENCE_XML


_SELECTS_LOOPBACK = re.compile(
    r"""<NetworkInterface\b[^>]*\b(?:name\s*=\s*["']lo["']|address\s*=\s*["']127\.)"""
    r"|<NetworkInterfaceAddress>\s*(?:lo|127\.[0-9.]+)\s*<",
    re.IGNORECASE,
)


def _selects_loopback(uri: str) -> bool:
    """Whether a ``CYCLONEDDS_URI`` (inline XML and files named by ``file://`` or an absolute
    path, comma-separated) selects the loopback interface itself."""
    texts = [uri]
    for match in _FILE_ITEM.finditer(uri):
        try:
            texts.append(Path(match.group(1)).read_text(encoding="utf-8", errors="replace"))
        except OSError:
            continue  # Cyclone reports a file it cannot read itself
    return any(_SELECTS_LOOPBACK.search(t) for t in texts)


_FILE_ITEM = re.compile(r"(?:^|,)\s*(?:file://)?(/[^,<>]*?)\s*(?=,|$)")


def make_participant(
    domain_id: int,
    *,
    localhost: bool = False,
    app_name: str = "paramdds",
    topic_discovery: bool = False,
    short_lived: bool = False,
    identity: Grants | None = None,
) -> Participant:
    """A participant on ``domain_id`` (0..232), configured as the module docstring says.

    With an ``identity`` (:func:`paramdds.secure.identity.load_identity`) the participant
    authenticates with it, and its transport is the secure one: readers, writers and samples
    are scoped by node partitions (:mod:`.transport`).

    Raises ``ValueError`` for a domain id out of range, or when this process
    already uses ``domain_id`` with a different configuration (Cyclone allows
    one per domain id per process).
    """
    if not 0 <= domain_id <= MAX_DOMAIN_ID:
        raise ValueError(f"DDS domain id must be in 0..{MAX_DOMAIN_ID}, got {domain_id}")
    from cyclonedds.core import DDSException
    from cyclonedds.qos import Policy, Qos

    from .transport import Participant

    qos = Qos(Policy.EntityName(app_name), Policy.Property("__ProcessName", app_name, propagate=True))
    security = "" if identity is None else identity.security_config(domain_id)
    if identity is not None:  # its certificate, which peers check against this participant's GUID
        certificate = (identity.path / "cert.pem").read_text()
        qos += Qos(Policy.Property(CERTIFICATE_PROPERTY, certificate, propagate=True))
    config = participant_config(
        localhost=localhost, topic_discovery=topic_discovery, short_lived=short_lived, security=security
    )
    with _lock:
        try:
            domain = _domain(domain_id, config)
        except DDSException as exc:
            options = {"localhost": localhost, "topic_discovery": topic_discovery, "short_lived": short_lived}
            if domain_config(**options, security=security) is not None or exc.code != PRECONDITION_NOT_MET:
                raise
            # The application made this domain itself (its own DomainParticipant): join it as
            # paramdds did before the coexistence setting, which it then lacks (said once).
            _warn_existing(domain_id)
            return Participant(domain_id, qos, grants=identity)
        participant = Participant(domain_id, qos, domain=domain, grants=identity)
        _domains[domain_id].users += 1
        return participant


_warned: set[int] = set()
PRECONDITION_NOT_MET = -4  # DDS_RETCODE_PRECONDITION_NOT_MET: dds_create_domain on an existing domain


def _warn_existing(domain_id: int) -> None:
    if domain_id not in _warned:
        _warned.add(domain_id)
        log.warning(
            "DDS domain %d already exists in this process (made by the application): paramdds joins it "
            "as it is, without %s (add it to CYCLONEDDS_URI to share a domain with ROS 2 on Fast DDS)",
            domain_id,
            ROS_COEXISTENCE_XML,
        )


def peer_mismatches(participant: DomainParticipant) -> list[PeerMismatch]:
    """The peers Cyclone refused to match with ``participant``'s endpoints, so far (see :mod:`.peers`).

    Looks into new incompatible-QoS events first, on this thread.
    """
    watch = _peers(participant)
    return [] if watch is None else watch.check()


def poll_peers(participant: DomainParticipant) -> None:
    """Look into new incompatible-QoS events in the background (a dispatch loop's tick)."""
    watch = _peers(participant)
    if watch is not None:
        watch.poll()


def _peers(participant: DomainParticipant) -> PeerWatch | None:
    from .transport import Participant

    return participant.peers if isinstance(participant, Participant) else None


def _domain(domain_id: int, config: str) -> Domain:
    from cyclonedds.core import DDSException
    from cyclonedds.domain import Domain

    held = _domains.get(domain_id)
    if held is not None:
        if held.config != config:
            raise ValueError(
                f"DDS domain {domain_id} is already in use in this process with another configuration"
            )
        return held.domain
    try:
        domain = Domain(domain_id, config)
    except DDSException as exc:  # still a DDS failure (the CLI exits 4), with what to look at
        raise DDSException(
            exc.code,
            f"cannot configure DDS domain {domain_id}: the configuration is invalid "
            f"(CYCLONEDDS_URI: interfaces, peers), or the domain already exists in this process "
            f"without paramdds's configuration ({exc.msg})",
        ) from exc
    _domains[domain_id] = _Held(config, domain)
    return domain


def _release(participant: DomainParticipant) -> None:
    """The participant no longer uses its Domain: delete the Domain if it was the last one."""
    from cyclonedds.core import Entity

    domain = getattr(participant, "domain", None)
    if domain is None:
        return
    participant.domain = None  # type: ignore[attr-defined]  # released once, however often closed
    with _lock:
        for domain_id, held in list(_domains.items()):
            if held.domain is domain:
                held.users -= 1
                if held.users <= 0:
                    del _domains[domain_id]
                    Entity.__del__(domain)
                return


def close_participant(participant: DomainParticipant) -> None:
    """Delete ``participant`` and everything in it now, telling its peers.

    Python does not delete Cyclone entities at interpreter exit, so a process that
    just exits stays known to its peers for the 10 s participant lease: their
    reliable writers keep data for its readers, and a server's reply writer can
    stall. Every paramdds process calls this on its way out (close readers' users
    such as dispatch threads first). Calling it twice is harmless.
    """
    from cyclonedds.core import Entity

    watch = _peers(participant)
    if watch is not None:
        watch.close()
    Entity.__del__(participant)
    _release(participant)
