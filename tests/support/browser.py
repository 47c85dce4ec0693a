"""How the browser tests run Chromium: headless, as root in CI, with no traffic of its own."""

from __future__ import annotations

# the same flags as `paramdds bench web` (paramdds/bench/web.py): a test's browser and the
# benchmark's run alike, but each front end says for itself how it starts a browser
CHROMIUM_FLAGS = [
    "--headless",
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
]
