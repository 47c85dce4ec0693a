"""Zenoh access control by certificate common name: who may use which sites' keys.

``grants`` maps a TLS certificate's common name to the sites it may use (``*``: every
site); :func:`access_control` returns the ``access_control`` section of a router's
configuration: default deny, and for each name every message kind on
``paramdds/<site>/**`` of its sites, both flows. A gateway's certificate granted its
own site may publish, answer and hold tokens only there; an operator's granted some
sites reaches only those; a session whose certificate is not named reaches nothing
(and one without a valid certificate does not even connect under mutual TLS).

Every named certificate may also see the gateways' liveliness tokens of every site
(``paramdds/*/gateway/**``: ask for them and follow them, never declare one), so that a
client told no gateway of a site answers its call can say whether the site is down or
not granted to it (:mod:`.client`).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

from ..errors import ParamddsError
from . import keys

MESSAGES = [
    "put",
    "delete",
    "declare_subscriber",
    "query",
    "declare_queryable",
    "reply",
    "liveliness_token",
    "declare_liveliness_subscriber",
    "liveliness_query",
]


def parse_grant(text: str) -> tuple[str, list[str]]:
    """``CN=SITE[,SITE...]`` (``*`` for every site) -> (common name, sites)."""
    name, sep, sites = text.partition("=")
    if not sep or not name or not sites:
        raise ParamddsError(f"a grant is COMMON_NAME=SITE[,SITE...] ('*': every site), got {text!r}")
    out = [s.strip() for s in sites.split(",") if s.strip()]
    for s in out:
        if s != "*":
            keys.check_site(s)
    return name.strip(), out


GATEWAYS = f"{keys.PREFIX}/*/gateway/**"  # every site's gateway tokens: visible to every named certificate
_SEE_GATEWAYS = [
    {  # ask for the gateways' tokens and follow them ...
        "id": "gateways_in",
        "messages": ["liveliness_query", "declare_liveliness_subscriber"],
        "flows": ["ingress"],
        "permission": "allow",
        "key_exprs": [GATEWAYS],
    },
    {  # ... and receive them (never declare one: that is a gateway's, on its granted site)
        "id": "gateways_out",
        "messages": ["liveliness_token", "liveliness_query", "declare_liveliness_subscriber", "reply"],
        "flows": ["egress"],
        "permission": "allow",
        "key_exprs": [GATEWAYS],
    },
]


def access_control(grants: Mapping[str, Sequence[str]]) -> dict[str, Any]:
    rules: list[dict[str, Any]] = [dict(rule) for rule in _SEE_GATEWAYS]
    subjects: list[dict[str, Any]] = []
    policies: list[dict[str, Any]] = []
    for k, (name, sites) in enumerate(sorted(grants.items())):
        rule_id, subject_id = f"r{k}", f"s{k}"
        rules.append(
            {
                "id": rule_id,
                "messages": MESSAGES,
                "flows": ["ingress", "egress"],
                "permission": "allow",
                "key_exprs": [f"{keys.PREFIX}/{s}/**" if s != "*" else f"{keys.PREFIX}/**" for s in sites],
            }
        )
        subjects.append({"id": subject_id, "cert_common_names": [name]})
        policies.append({"rules": [rule_id, *(r["id"] for r in _SEE_GATEWAYS)], "subjects": [subject_id]})
    return {
        "enabled": True,
        "default_permission": "deny",
        "rules": rules,
        "subjects": subjects,
        "policies": policies,
    }
