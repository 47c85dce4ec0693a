"""Build Cyclone DDS C with DDS Security and install the Python binding against it.

``python -m paramdds.secure.install --source SRC --prefix DIR`` (also
``paramdds keystore install``):

1. unpacks ``SRC`` (a ``.tar.gz`` of the Cyclone C 11.0.1 sources, or a directory
   holding them) into ``DIR/src`` unless it is a directory already;
2. configures it with CMake (security and OpenSSL on, shared memory, tests and
   examples off; Ninja when installed), builds and installs it into ``DIR``;
3. rebuilds the ``cyclonedds`` binding 11.0.1 from PyPI's source package against
   ``DIR`` into the running interpreter's environment
   (``CYCLONEDDS_HOME=DIR pip install --no-binary cyclonedds``);
4. writes ``paramdds_secure.pth`` into that environment's site-packages, which sets
   ``CYCLONEDDS_HOME=DIR`` (unless already set) when Python starts, so every
   ``paramdds`` command and script of that environment loads the secure library.
   Without it the binding would find no library, or Debian's older ``libddsc``.

A build already in ``DIR`` (``DIR/lib/libdds_security_auth.so`` present and the
same source stamp) is reused: the step costs a few seconds then.
"""

from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import sysconfig
import tarfile
from pathlib import Path

__all__ = ["BINDING_VERSION", "CMAKE_OPTIONS", "build_cyclone", "install", "install_binding", "main"]

BINDING_VERSION = "11.0.1"
UPSTREAM = "https://github.com/eclipse-cyclonedds/cyclonedds/archive/refs/tags/11.0.1.tar.gz"
CMAKE_OPTIONS = (
    "-DCMAKE_BUILD_TYPE=Release",
    "-DENABLE_SECURITY=ON",
    "-DENABLE_SSL=ON",
    "-DENABLE_SHM=OFF",
    "-DBUILD_TESTING=OFF",
    "-DBUILD_EXAMPLES=OFF",
    "-DBUILD_IDLC=ON",
)
PTH_NAME = "paramdds_secure.pth"
_STAMP = ".paramdds-source"


class InstallError(Exception):
    """A step of the secure install failed; the message says which and what to do."""


def _run(cmd: list[str], log: Path, env: dict[str, str] | None = None) -> None:
    with log.open("a") as out:
        out.write("$ " + " ".join(cmd) + "\n")
        out.flush()
        done = subprocess.run(cmd, stdout=out, stderr=subprocess.STDOUT, env=env, check=False)
    if done.returncode != 0:
        tail = log.read_text(errors="replace").splitlines()[-15:]
        raise InstallError(f"{cmd[0]} failed (exit {done.returncode}); log {log}:\n" + "\n".join(tail))


def _source_dir(source: Path, work: Path) -> Path:
    if source.is_dir():
        return source
    if not source.is_file():
        raise InstallError(f"{source}: no such file or directory (give the Cyclone DDS C 11.0.1 sources)")
    target = work / "src"
    shutil.rmtree(target, ignore_errors=True)
    target.mkdir(parents=True)
    with tarfile.open(source) as tar:
        if hasattr(tarfile, "data_filter"):  # Python 3.10.12+: refuse paths outside target
            tar.extractall(target, filter="data")
        else:  # pragma: no cover - older Pythons
            tar.extractall(target)
    entries = [p for p in target.iterdir() if p.is_dir()]
    root = entries[0] if len(entries) == 1 else target
    if not (root / "CMakeLists.txt").is_file():
        raise InstallError(f"{source}: no CMakeLists.txt at the top of the archive")
    return root


def _stamp_of(source: Path) -> str:
    """What a build in a prefix was made from: the sources (path, size, time) and the options."""
    st = source.stat()
    return f"{source.resolve()} {st.st_size} {int(st.st_mtime)} {' '.join(CMAKE_OPTIONS)}"


def build_cyclone(source: Path, prefix: Path, *, jobs: int | None = None) -> Path:
    """Build and install Cyclone C with security into ``prefix`` (reused when already there)."""
    prefix = prefix.resolve()
    prefix.mkdir(parents=True, exist_ok=True)
    stamp = prefix / _STAMP
    built = (prefix / "lib" / "libdds_security_auth.so").is_file() and stamp.is_file()
    if built and stamp.read_text() == _stamp_of(source):
        return prefix
    for tool in ("cmake", "cc"):
        if shutil.which(tool) is None:
            raise InstallError(
                f"{tool} not found: install the build tools "
                "(Debian: apt-get install cmake gcc libssl-dev ninja-build)"
            )
    log = prefix / "build.log"
    log.write_text("")
    work = prefix / "build"
    src = _source_dir(source, work)
    generator = ["-G", "Ninja"] if shutil.which("ninja") else []
    _run(
        [
            "cmake",
            "-S",
            str(src),
            "-B",
            str(work / "cmake"),
            *generator,
            f"-DCMAKE_INSTALL_PREFIX={prefix}",
            *CMAKE_OPTIONS,
        ],
        log,
    )
    parallel = ["--parallel", str(jobs or os.cpu_count() or 1)]
    _run(["cmake", "--build", str(work / "cmake"), "--target", "install", *parallel], log)
    if not (prefix / "lib" / "libdds_security_auth.so").is_file():
        raise InstallError(f"the build has no security plugins (is libssl-dev installed? see {log})")
    shutil.rmtree(work, ignore_errors=True)
    stamp.write_text(_stamp_of(source))
    return prefix


def install_binding(prefix: Path, python: str = sys.executable) -> Path:
    """Rebuild the cyclonedds binding against ``prefix`` into ``python``'s environment; the .pth path."""
    env = dict(os.environ, CYCLONEDDS_HOME=str(prefix))
    log = prefix / "binding.log"
    log.write_text("")
    _run(
        [
            python,
            "-m",
            "pip",
            "install",
            "--force-reinstall",
            "--no-deps",
            "--no-binary",
            "cyclonedds",
            f"cyclonedds=={BINDING_VERSION}",
        ],
        log,
        env,
    )
    purelib = subprocess.run(
        [python, "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
        capture_output=True,
        text=True,
        check=True,
    ).stdout.strip()
    pth = Path(purelib) / PTH_NAME
    pth.write_text(f"import os; os.environ.setdefault('CYCLONEDDS_HOME', {str(prefix)!r})\n")
    return pth


def install(source: Path, prefix: Path, python: str = sys.executable) -> Path:
    """Both steps; returns the prefix."""
    prefix = build_cyclone(source, prefix)
    install_binding(prefix, python)
    return prefix


def _default_source(work: Path) -> Path:
    """Download the upstream tag (for users with internet access)."""
    import urllib.request

    target = work / "cyclonedds-11.0.1.tar.gz"
    if not target.is_file():
        urllib.request.urlretrieve(UPSTREAM, target)
    return target


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "--source",
        metavar="TARBALL|DIR",
        help="Cyclone DDS C 11.0.1 sources (default: download the upstream tag)",
    )
    p.add_argument("--prefix", metavar="DIR", required=True, help="where to install the secure Cyclone build")


def run(args: argparse.Namespace) -> int:
    prefix = Path(args.prefix).resolve()
    prefix.mkdir(parents=True, exist_ok=True)
    source = Path(args.source) if args.source else _default_source(prefix)
    try:
        install(source, prefix)
    except InstallError as exc:
        sys.stderr.write(f"paramdds: error: {exc}\n")
        return 4
    sys.stdout.write(
        f"Cyclone DDS with security is in {prefix}; the cyclonedds binding of "
        f"{sysconfig.get_paths()['purelib']} now uses it (every paramdds command of this environment; "
        f"elsewhere: export CYCLONEDDS_HOME={prefix})\n"
    )
    return 0


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m paramdds.secure.install", description=__doc__.splitlines()[0])
    add_arguments(p)
    return run(p.parse_args(argv))


if __name__ == "__main__":
    raise SystemExit(main())
