"""Building the foreign participants of ``examples/`` once per test session.

Both programs (``examples/cyclone_c``: C on Cyclone DDS C 0.10 with idlc;
``examples/fastdds_cpp``: C++ on Fast DDS 2.x with fastddsgen) are built with
CMake from ``idl/paramdds.idl``, the way their READMEs say, into a cache
directory keyed by a hash of their sources and the IDL
(``$PARAMDDS_INTEROP_CACHE``, default ``~/.cache/paramdds/interop``): a second
run, or the second vendor's tests, reuse the binaries. The two builds run in
parallel.

Where a toolchain is missing the vendor's tests skip, naming the Debian
packages to install; in CI (``CI`` set to true) a missing toolchain is a
failure, so the interop checks can never silently drop out of ``.ci/run``.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import subprocess
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
IDL = ROOT / "idl" / "paramdds.idl"


@dataclass(frozen=True)
class Vendor:
    name: str  # the folder under examples/
    packages: str  # what to apt-get install
    tools: tuple[str, ...]  # programs the build needs on PATH
    prefix: str  # the parameter names its node hosts start with this

    @property
    def source(self) -> Path:
        return ROOT / "examples" / self.name


VENDORS = {
    "cyclone_c": Vendor(
        "cyclone_c", "cyclonedds-dev cyclonedds-tools libddsc0debian cmake gcc", ("cmake", "idlc", "cc"), "c."
    ),
    "fastdds_cpp": Vendor(
        "fastdds_cpp",
        "libfastrtps-dev libfastcdr-dev fastddsgen cmake g++",
        ("cmake", "fastddsgen", "c++"),
        "cpp.",
    ),
}


def _in_ci() -> bool:
    return os.environ.get("CI", "").strip().lower() in {"1", "true", "yes"}


def _fingerprint(vendor: Vendor) -> str:
    digest = hashlib.sha256()
    for path in sorted([IDL, *vendor.source.iterdir()]):
        if path.is_file():
            digest.update(path.name.encode() + b"\0" + path.read_bytes())
    return digest.hexdigest()[:16]


def _build(vendor: Vendor, cache: Path) -> Path | str:
    """The built program, or why it could not be built."""
    missing = [tool for tool in vendor.tools if shutil.which(tool) is None]
    if missing:
        return f"{', '.join(missing)} not found: apt-get install {vendor.packages}"
    out = cache / f"{vendor.name}-{_fingerprint(vendor)}"
    program = out / "paramdds_peer"
    if program.is_file():
        return program
    work = out.with_name(out.name + f".tmp{os.getpid()}")
    shutil.rmtree(work, ignore_errors=True)
    for step in (
        ["cmake", "-S", str(vendor.source), "-B", str(work), "-DCMAKE_BUILD_TYPE=Release"],
        ["cmake", "--build", str(work)],
    ):
        done = subprocess.run(step, capture_output=True, text=True, timeout=600)
        if done.returncode != 0:
            return (
                f"{' '.join(step[:2])} failed for {vendor.name}:\n{done.stdout[-3000:]}{done.stderr[-3000:]}"
            )
    shutil.rmtree(out, ignore_errors=True)
    work.rename(out)  # whole or not at all: a half-built cache entry never exists
    return program


def build_programs() -> dict[str, Path | str]:
    """Vendor name -> built program (or the reason it is missing), from the cache when built."""
    cache = Path(os.environ.get("PARAMDDS_INTEROP_CACHE", Path.home() / ".cache" / "paramdds" / "interop"))
    cache.mkdir(parents=True, exist_ok=True)
    with ThreadPoolExecutor(len(VENDORS)) as pool:
        futures = {name: pool.submit(_build, vendor, cache) for name, vendor in VENDORS.items()}
        return {name: future.result() for name, future in futures.items()}


def require_program(name: str, built: Path | str) -> Path:
    """The program, or skip naming what is missing (fail in CI, and for a broken build)."""
    if isinstance(built, str):
        if _in_ci() or "failed" in built:  # a broken build is a failure everywhere
            pytest.fail(f"{name}: {built}")
        pytest.skip(f"{name}: {built}")
    return built


@pytest.fixture(scope="session")
def foreign_programs() -> dict[str, Path | str]:
    """Vendor name -> built program (or the reason it is missing), built once per session."""
    return build_programs()


@pytest.fixture(params=sorted(VENDORS))
def vendor(request: pytest.FixtureRequest, foreign_programs: dict[str, Path | str]) -> tuple[Vendor, Path]:
    """Each interop test runs once per vendor, with that vendor's program."""
    return VENDORS[request.param], require_program(request.param, foreign_programs[request.param])
