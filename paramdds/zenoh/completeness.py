"""Which sites a remote view lacks: the sites known, and which of them answered.

Pure: :class:`SiteLedger` is told the sites an operator named, the sites whose gateway
was seen, and the sites whose state query was answered in full; :meth:`SiteLedger.missing`
says which known site a view lacks, and why. A site is *known* when it is named (a
``SITE/NODE`` glob of an exact site, ``PARAMDDS_ZENOH_SITES``, ``sites=[...]``) or when
any of its gateways or nodes was seen; it *answered* when a gateway of it was up and its
state query ended before its timeout (every gateway serving it sent all its states). A
site whose nodes hold liveliness tokens but whose states did not all arrive lacks them,
and so does a site whose every gateway went since (``down``: killed, or its uplink cut).
When no site is known at all, the view lacks every site (:data:`EVERY_SITE`): nothing
answered, which an empty fleet, a router with no gateway and a certificate granted no
site all look like. A site whose gateway is up but serves this client nothing is
*refused*: the router's access control does not grant this client's certificate the site.
"""

from __future__ import annotations

import threading
from collections.abc import Iterable
from typing import NamedTuple

EVERY_SITE = "*"  # the key of :meth:`SiteLedger.missing` when no site is known at all


class Lack(NamedTuple):
    """Why a view lacks a site; ``refused``: the site is not granted to this client."""

    reason: str
    refused: bool = False

    @property
    def status(self) -> str:
        """The word a row of the site shows: ``not granted``, or ``no answer``."""
        return "not granted" if self.refused else "no answer"


class SiteLedger:
    """The sites a remote view knows, and which of them answered; thread-safe."""

    def __init__(self, named: Iterable[str] = ()) -> None:
        self._lock = threading.Lock()
        self._named = set(named)
        self._up: set[str] = set()  # a gateway of the site was seen
        self._seen: set[str] = set()  # a node or a gateway of the site was seen
        self._answered: set[str] = set()
        self._refused: set[str] = set()

    def gateways_up(self, sites: Iterable[str]) -> None:
        with self._lock:
            self._up.update(sites)
            self._seen.update(sites)

    def nodes_seen(self, sites: Iterable[str]) -> None:
        with self._lock:
            self._seen.update(sites)

    def answered(self, sites: Iterable[str]) -> None:
        """The state queries of ``sites`` ended before their timeout."""
        with self._lock:
            self._answered.update(s for s in sites if s in self._up)

    def refused(self, sites: Iterable[str]) -> None:
        """A gateway of each of ``sites`` is up, but none serves this client."""
        with self._lock:
            self._refused.update(sites)

    def is_up(self, site: str) -> bool:
        with self._lock:
            return site in self._up

    def known(self) -> set[str]:
        with self._lock:
            return self._named | self._seen

    def missing(self, lacking: Iterable[str] = (), down: Iterable[str] = ()) -> dict[str, Lack]:
        """Why each known site is lacking from the view (none: the view is complete);
        ``lacking``: sites with a node alive whose state is not held; ``down``: sites seen up
        whose every gateway went since."""
        short, gone = set(lacking), set(down)
        with self._lock:
            known = self._named | self._seen
            if not known:
                return {
                    EVERY_SITE: Lack(
                        "no gateway of any site is reachable (none connected, or this client is "
                        "granted no site: name the sites in PARAMDDS_ZENOH_SITES)"
                    )
                }
            lacks: dict[str, Lack] = {}
            for site in sorted(known):
                if site not in self._up or site in gone:
                    lacks[site] = Lack(
                        f"no gateway of site {site!r} is reachable (site not connected, its uplink "
                        "down, or this client not granted it)"
                    )
                elif site in self._refused:
                    lacks[site] = Lack(
                        f"site {site!r} is not granted to this client (its gateway is up, but the "
                        "router's access control refuses this certificate the site)",
                        refused=True,
                    )
                elif site not in self._answered:
                    lacks[site] = Lack(f"site {site!r} did not answer in time (its state query did not end)")
                elif site in short:
                    lacks[site] = Lack(f"site {site!r}: the state of some of its online nodes did not arrive")
            return lacks


def lacking_line(site: str, lack: Lack) -> str:
    """What a view tells its reader of a site it lacks (one line)."""
    if site == EVERY_SITE:
        return f"the answer may lack every site: {lack.reason}"
    return f"the answer lacks site {site!r}: {lack.reason}"


def lacking_exit(lacks: dict[str, Lack]) -> int:
    """The exit code of a view that lacks ``lacks``: 0 when it lacks nothing; 1 (a refusal)
    when every site lacking is not granted to this client; else 3 (a site not reached)."""
    if not lacks:
        return 0
    return 1 if all(lack.refused for lack in lacks.values()) else 3
