"""What a keystore grants and an identity directory holds: the roles, the metadata file's
name and the domain ids a governance covers (read by :mod:`.keystore` and :mod:`.identity`)."""

from __future__ import annotations

__all__ = ["GOVERNANCE_MAX_DOMAIN", "META", "REPLIES", "REQUESTS", "ROLES", "STATE"]

GOVERNANCE_MAX_DOMAIN = 230  # Cyclone refuses a governance with domain ids above 230
STATE = "ParameterEvents"
REQUESTS = {"set": "SetParametersRequest", "get": "GetParametersRequest", "list": "ListParametersRequest"}
REPLIES = {"set": "SetParametersResponse", "get": "GetParametersResponse", "list": "ListParametersResponse"}

# role -> (topics published, topics subscribed)
ROLES: dict[str, tuple[tuple[str, ...], tuple[str, ...]]] = {
    "server": ((STATE, *REPLIES.values()), (*REQUESTS.values(), STATE)),
    "operator": (tuple(REQUESTS.values()), (*REPLIES.values(), STATE)),
    "viewer": ((REQUESTS["get"], REQUESTS["list"]), (REPLIES["get"], REPLIES["list"], STATE)),
    "admin": ((STATE, *REQUESTS.values(), *REPLIES.values()), (STATE, *REQUESTS.values(), *REPLIES.values())),
}
META = "paramdds.json"  # an identity directory's name, role and node globs
