"""The documentation site builds strict, offline, and loads nothing from another host.

``mkdocs build --strict`` fails on a broken link, a missing anchor or an API
reference that does not resolve; .ci/run runs it too. Then every built page is
read: a script, stylesheet, font or image from another host would make the site
depend on a CDN when it is viewed.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
MKDOCS = Path(sys.executable).with_name("mkdocs")
# What a browser loads by itself: src=, <link href=>, CSS url() and @import.
LOADED = re.compile(
    r"""(?:\bsrc\s*=\s*["']?|<link\b[^>]*\bhref\s*=\s*["']?|url\(\s*["']?|@import\s+["'])(?P<url>[^"')\s>]+)""",
    re.IGNORECASE,
)


@pytest.fixture(scope="module")
def site(tmp_path_factory: pytest.TempPathFactory) -> Path:
    if not MKDOCS.exists():
        if os.environ.get("CI") == "true":
            pytest.fail("mkdocs is not installed (the test and docs extras bring it)")
        pytest.skip("mkdocs is not installed: pip install -e '.[docs]'")
    out = tmp_path_factory.mktemp("site")
    env = dict(os.environ, NO_MKDOCS_2_WARNING="1")
    done = subprocess.run(
        [str(MKDOCS), "build", "--strict", "--site-dir", str(out)],
        cwd=ROOT, env=env, capture_output=True, text=True, timeout=120,
    )
    assert done.returncode == 0, done.stderr
    return out


def test_every_page_is_built_with_the_readme_as_home(site: Path) -> None:
    pages = {p.parent.name for p in site.glob("*/index.html")}
    docs = {p.stem for p in (ROOT / "docs").glob("*.md")} - {"index"}
    assert docs <= pages
    home = (site / "index.html").read_text(encoding="utf-8")
    assert "A 30-second tour" in home
    assert 'href="cli/"' in home  # the README's docs/cli.md, rewritten for the site


def test_the_api_reference_is_generated_from_the_docstrings(site: Path) -> None:
    text = (site / "api-reference" / "index.html").read_text(encoding="utf-8")
    for anchor in ("dds.client.ParameterClient", "dds.server.ParameterServer",
                   "dds.monitor.ParameterMonitor", "core.table.ParameterTable",
                   "dds.client.ParameterClient.wait_for_node"):
        assert f'id="paramdds.{anchor}"' in text


def test_nothing_is_loaded_from_another_host(site: Path) -> None:
    foreign = []
    for path in site.rglob("*"):
        if path.suffix not in (".html", ".css"):
            continue
        for m in LOADED.finditer(path.read_text(encoding="utf-8", errors="replace")):
            url = m["url"]
            if re.match(r"(?:https?:)?//", url):
                foreign.append(f"{path.relative_to(site)}: {url}")
    assert not foreign, "\n".join(foreign)
