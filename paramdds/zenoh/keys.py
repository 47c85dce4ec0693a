"""The key expressions of paramdds on Zenoh: the wire contract (docs/zenoh.md).

Every key starts ``paramdds/<site>``; a node's keys sit under ``paramdds/<site>/node/<node>``
with its id escaped into one key chunk (a node id's segments are joined by ``/``, which
separates key chunks, so ``/`` is written ``%``, as rmw_zenoh does; ``%`` never occurs in a
node id)::

    paramdds/<site>/node/<node>/state     the node's state: published on every change, queryable
    paramdds/<site>/node/<node>/get       query: values (and descriptors) of names
    paramdds/<site>/node/<node>/list      query: names and prefixes
    paramdds/<site>/node/<node>/set       query: set / atomic set / delete / compare-and-set
    paramdds/<site>/node/<node>/history   query: one page of the node's history
    paramdds/<site>/node/<node>/alive     liveliness token, held while the node is online
    paramdds/<site>/gateway/<id>          liveliness token of each gateway of the site
    paramdds/<site>/gateway/<id>/active/<since>   liveliness token of the active one

A site name is one key chunk and one node-id segment: ASCII letters, digits and ``_``.
A remote node is named ``<site>/<node>``: ``warehouse1/robot1``, ``warehouse1/ns/robot1``.
"""

from __future__ import annotations

import re

from ..core.names import canonical_node_id
from ..errors import InvalidNameError

PREFIX = "paramdds"
VERBS = ("get", "list", "set", "history")
STATE = "state"
ALIVE = "alive"
_SITE = re.compile(r"[A-Za-z0-9_]{1,64}")


def check_site(site: str) -> str:
    """``site`` if it is a valid site name, else InvalidNameError saying why."""
    if not isinstance(site, str) or not _SITE.fullmatch(site):
        raise InvalidNameError(
            f"invalid site name {site!r}: 1 to 64 ASCII letters, digits or '_' "
            "(a site is one Zenoh key chunk and the first segment of a remote node name)"
        )
    return site


def escape_node(node: str) -> str:
    """A node id as one key chunk: ``ns/robot1`` -> ``ns%robot1``."""
    return canonical_node_id(node).replace("/", "%")


def unescape_node(chunk: str) -> str:
    """The node id a key chunk stands for (InvalidNameError for one that is not one)."""
    return canonical_node_id(chunk.replace("%", "/"))


def node_key(site: str, node: str, leaf: str) -> str:
    """``paramdds/<site>/node/<node>/<leaf>`` (leaf: state, alive, or a verb)."""
    return f"{PREFIX}/{check_site(site)}/node/{escape_node(node)}/{leaf}"


def site_pattern(site: str, leaf: str) -> str:
    """Every node of ``site`` (``*``: every site): ``paramdds/<site>/node/*/<leaf>``."""
    if site != "*":
        check_site(site)
    return f"{PREFIX}/{site}/node/*/{leaf}"


def gateway_key(site: str, zid: str) -> str:
    return f"{PREFIX}/{check_site(site)}/gateway/{zid}"


def gateways_pattern(site: str) -> str:
    """The tokens of every gateway of ``site`` (``*``: every site), not the active ones'."""
    if site != "*":
        check_site(site)
    return f"{PREFIX}/{site}/gateway/*"


def active_key(site: str, gateway: str, since: int) -> str:
    """The token of the active gateway ``gateway`` of ``site``, active since ``since`` (ns)."""
    return f"{gateway_key(site, gateway)}/active/{since}"


def parse_gateway_key(key: str) -> tuple[str, int | None]:
    """(gateway id, None) of a gateway's token, (gateway id, since) of an active one's;
    InvalidNameError for anything else."""
    parts = key.split("/")
    if len(parts) == 4 and parts[0] == PREFIX and parts[2] == "gateway":
        return parts[3], None
    if len(parts) == 6 and parts[:5:2] == [PREFIX, "gateway", "active"] and parts[5].isdigit():
        return parts[3], int(parts[5])
    raise InvalidNameError(f"not a paramdds gateway key: {key!r}")


def parse_node_key(key: str) -> tuple[str, str, str]:
    """(site, node, leaf) of a concrete node key; InvalidNameError for anything else."""
    parts = key.split("/")
    if len(parts) != 5 or parts[0] != PREFIX or parts[2] != "node":
        raise InvalidNameError(f"not a paramdds node key: {key!r}")
    return check_site(parts[1]), unescape_node(parts[3]), parts[4]


def split_remote(name: str) -> tuple[str, str]:
    """``site/node`` -> (site, node id). A leading ``/`` is dropped, as for node ids."""
    text = name[1:] if name.startswith("/") else name
    site, sep, node = text.partition("/")
    if not sep or not node:
        raise InvalidNameError(f"a node reached over Zenoh is named SITE/NODE, got {name!r}")
    return check_site(site), canonical_node_id(node)


def remote_name(site: str, node: str) -> str:
    return f"{site}/{node}"
