"""``paramdds web``: the console lives in :mod:`paramdds.web`; this only checks the extra is there."""

from __future__ import annotations

import argparse
import importlib.util

from ._errors import UsageError

WEB_PACKAGES = ("starlette", "uvicorn")


def run_web(args: argparse.Namespace) -> int:
    missing = [name for name in WEB_PACKAGES if importlib.util.find_spec(name) is None]
    if missing:
        raise UsageError(
            f"'paramdds web' needs the web extra ({', '.join(missing)} not installed): "
            "pip install 'paramdds[web]'"
        )
    from ..web.serve import run_web as serve

    return serve(args)
