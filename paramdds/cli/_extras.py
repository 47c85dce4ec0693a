"""The optional extras a verb needs, and the one error a user gets without them."""

from __future__ import annotations

import importlib.util

from ..exits import UsageError

# the packages each extra of pyproject.toml brings that paramdds imports
PACKAGES = {
    "web": ("starlette", "uvicorn"),
    "foxglove": ("websockets", "mcap"),
    "secure": ("cryptography",),
}


def install_hint(extra: str) -> str:
    """How to install ``extra``, as the docs say it (paramdds is installed from its checkout)."""
    return f"pip install -e '.[{extra}]' in the paramdds checkout"


def require_extra(what: str, extra: str, packages: tuple[str, ...] | None = None) -> None:
    """UsageError (exit 2) saying ``what`` needs ``extra`` when any of its ``packages`` (default:
    all the extra brings) is not installed; nothing is done before that is known."""
    wanted = PACKAGES[extra] if packages is None else packages
    missing = [name for name in wanted if importlib.util.find_spec(name) is None]
    if missing:
        raise UsageError(
            f"{what} needs the {extra} extra ({', '.join(missing)} not installed): {install_hint(extra)}"
        )
