"""MkDocs hooks: the README is the site's home page.

``docs/index.md`` is a placeholder; its content is replaced by ``README.md``, whose
links point into ``docs/`` from the repository root (``docs/cli.md``), rewritten
here to the site's own (``cli.md``). So the README stays the one source of the
introduction, and a broken link in it fails ``mkdocs build --strict`` as well.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

_README = Path(__file__).resolve().parents[1] / "README.md"


def on_page_markdown(markdown: str, page: Any, **_: Any) -> str:
    if page.file.src_uri != "index.md":
        return markdown
    text = _README.read_text(encoding="utf-8")
    return re.sub(r"\]\(docs/", "](", text)
