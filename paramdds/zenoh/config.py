"""Zenoh configurations for gateways, remote clients and test routers.

A gateway or a remote client dials out as a Zenoh *client* by default (a site behind
NAT needs no open port); ``peer`` and ``router`` modes and listen endpoints are
options, and a standard Zenoh JSON5 configuration file is accepted for everything
else (the options given here override its keys). Multicast scouting is off unless the
file turns it on: sessions meet only where they are told to.

Every wait is bounded: opening a session that cannot reach any ``connect`` endpoint
fails after ``open_timeout`` seconds with UnavailableError (the CLI's exit 3). A gateway
instead waits for its WAN (:func:`open_session_waiting`): it tries again and again, with a
pause doubling from :data:`RETRY_FIRST` to :data:`RETRY_MAX` seconds between tries, forever
unless given a bound.
"""

from __future__ import annotations

import json
import logging
import re
import time
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

from ..errors import FileFormatError, ParamddsError, UnavailableError

log = logging.getLogger(__name__)

MODES = ("client", "peer", "router")
PROTOCOLS = ("tcp", "udp", "tls", "quic", "unixsock-stream", "ws")
LEASE_MS = 3000  # a session that stops answering is dropped (and its tokens with it) after this
RETRY_FIRST = 0.5  # seconds: the pause after a gateway's first failed try to reach its router
RETRY_MAX = 10.0  # seconds: the longest pause between two tries
TRY_TIMEOUT = 2.0  # seconds: how long one try waits for a router to answer
_ENDPOINT = re.compile(r"(?P<proto>[a-z][a-z0-9-]*)/(?P<addr>[^#?]+)(?P<rest>[#?].*)?")


def check_endpoint(text: str, *, error: type[Exception] = ParamddsError) -> str:
    """A Zenoh endpoint (``tcp/10.0.0.1:7447``, ``tls/[::1]:7447``), checked for shape."""
    m = _ENDPOINT.fullmatch(text.strip())
    if m is None or m["proto"] not in PROTOCOLS:
        raise error(
            f"invalid Zenoh endpoint {text!r}: want PROTOCOL/ADDRESS:PORT with PROTOCOL one of "
            + ", ".join(PROTOCOLS)
        )
    addr = m["addr"]
    if m["proto"] in ("tcp", "udp", "tls", "quic"):
        host, sep, port = addr.rpartition(":")
        if not sep or not host or not port.isdigit():
            raise error(f"invalid Zenoh endpoint {text!r}: the address needs HOST:PORT")
        if not 0 < int(port) < 65536:
            raise error(f"invalid Zenoh endpoint {text!r}: port {int(port)} is not within 1-65535")
    return text.strip()


@dataclass
class TlsFiles:
    """PEM files for mutual TLS: the CA that signed every peer, and this side's key and certificate."""

    root_ca: str
    certificate: str
    private_key: str

    def check(self) -> None:
        for what, path in (
            ("CA", self.root_ca),
            ("certificate", self.certificate),
            ("key", self.private_key),
        ):
            if not Path(path).is_file():
                raise ParamddsError(f"TLS {what} file not found: {path}")


@dataclass
class ZenohOptions:
    mode: str = "client"
    connect: list[str] = field(default_factory=list)
    listen: list[str] = field(default_factory=list)
    config_file: str | None = None
    tls: TlsFiles | None = None
    open_timeout: float = 10.0  # seconds to reach a connect endpoint at start
    lease_ms: int = LEASE_MS
    extra: dict[str, Any] = field(default_factory=dict)  # more "path/to/key": value pairs

    def check(self) -> None:
        if self.mode not in MODES:
            raise ParamddsError(f"invalid Zenoh mode {self.mode!r}: one of {', '.join(MODES)}")
        self.connect = [check_endpoint(e) for e in self.connect]
        self.listen = [check_endpoint(e) for e in self.listen]
        if self.mode == "client" and not self.connect and not self.config_file:
            raise ParamddsError("a Zenoh client needs an endpoint to connect to (--connect ENDPOINT)")
        if not self.open_timeout > 0:
            raise ParamddsError(f"the Zenoh open timeout must be positive, got {self.open_timeout}")
        if self.tls is not None:
            self.tls.check()


def build_config(options: ZenohOptions) -> Any:
    """A ``zenoh.Config`` for ``options`` (imports zenoh; ParamddsError on a bad file or key)."""
    zenoh = import_zenoh()
    options.check()
    if options.config_file:
        path = Path(options.config_file)
        if not path.is_file():
            raise FileFormatError("the Zenoh configuration file does not exist", file=str(path))
        try:
            config = zenoh.Config.from_file(str(path))
        except Exception as exc:  # zenoh.ZError: the file's line and column are in the message
            raise FileFormatError(f"not a valid Zenoh configuration: {exc}", file=str(path)) from None
    else:
        config = zenoh.Config()
        _insert(config, "scouting/multicast/enabled", False)
    pairs: dict[str, Any] = {"mode": options.mode}
    if options.connect:
        pairs["connect/endpoints"] = options.connect
    if options.listen:
        pairs["listen/endpoints"] = options.listen
    if not options.config_file and not options.listen:
        pairs["listen/endpoints"] = []  # a client or peer listens nowhere unless told to
    if options.connect or options.mode == "client":  # bounded, also for endpoints from a file
        pairs["connect/timeout_ms"] = int(options.open_timeout * 1000)
        pairs["connect/exit_on_failure"] = True
    pairs["transport/link/tx/lease"] = options.lease_ms
    if not options.config_file:
        # shared memory carries only a reference on the link between two local processes: a
        # gateway's uplink crosses a WAN, and the bench must count the bytes that would
        pairs["transport/shared_memory/enabled"] = False
    tls = options.tls
    if tls is not None:
        pairs.update(
            {
                "transport/link/tls/root_ca_certificate": tls.root_ca,
                "transport/link/tls/enable_mtls": True,
                "transport/link/tls/connect_private_key": tls.private_key,
                "transport/link/tls/connect_certificate": tls.certificate,
                "transport/link/tls/listen_private_key": tls.private_key,
                "transport/link/tls/listen_certificate": tls.certificate,
            }
        )
    pairs.update(options.extra)
    for key, value in pairs.items():
        _insert(config, key, value)
    return config


def _insert(config: Any, key: str, value: object) -> None:
    try:
        config.insert_json5(key, json.dumps(value))
    except Exception as exc:
        raise ParamddsError(f"Zenoh refused the configuration {key} = {value!r}: {exc}") from None


def open_session(options: ZenohOptions) -> Any:
    """A Zenoh session; UnavailableError (exit 3) when no connect endpoint answers in time."""
    zenoh = import_zenoh()
    config = build_config(options)
    try:
        return zenoh.open(config)
    except zenoh.ZError as exc:
        where = ", ".join(options.connect) or "the configured endpoints"
        text = str(exc).split(" at /", 1)[0]  # drop the Rust source location
        if "connect" in text.lower() or "timeout" in text.lower():
            raise UnavailableError(
                f"no Zenoh router reachable at {where} within {options.open_timeout:g} s ({text})"
            ) from None
        raise ParamddsError(f"could not open a Zenoh session: {text}") from None


def retry_delays(first: float = RETRY_FIRST, most: float = RETRY_MAX) -> Iterator[float]:
    """The pauses between tries: ``first``, doubling, then ``most`` forever."""
    delay = first
    while True:
        yield min(delay, most)
        delay = min(delay * 2, most)


def open_session_waiting(
    options: ZenohOptions,
    wait: float | None,
    *,
    sleep: Callable[[float], None] = time.sleep,
    clock: Callable[[], float] = time.monotonic,
) -> Any:
    """A Zenoh session, trying until a ``connect`` endpoint answers: each try waits up to
    :data:`TRY_TIMEOUT` seconds, each failure is logged (a warning) with the pause before the
    next (:func:`retry_delays`). ``wait`` bounds the whole (UnavailableError after it, as
    :func:`open_session`); None waits forever. Other errors (a refused configuration) end it
    at once."""
    started = clock()
    delays = retry_delays()
    where = ", ".join(options.connect) or "the configured endpoints"
    tries = 0
    while True:
        tries += 1
        left = None if wait is None else wait - (clock() - started)
        try_for = TRY_TIMEOUT if left is None else max(0.05, min(TRY_TIMEOUT, left))
        try:
            session = open_session(replace(options, open_timeout=try_for))
        except UnavailableError as exc:
            waited = clock() - started
            if wait is not None and waited + 1e-3 >= wait:
                raise UnavailableError(
                    f"no Zenoh router reachable at {where} within {wait:g} s "
                    f"({tries} {'try' if tries == 1 else 'tries'})"
                ) from exc
            pause = next(delays)
            if wait is not None:
                pause = min(pause, wait - waited)
            log.warning(
                "no Zenoh router reachable at %s (try %d, %.1f s since start): trying again in %.1f s",
                where,
                tries,
                waited,
                pause,
            )
            sleep(pause)
            continue
        if tries > 1:
            log.warning("reached the Zenoh router at %s at try %d", where, tries)
        return session


def import_zenoh() -> Any:
    try:
        import zenoh
    except ImportError as exc:
        raise ParamddsError(
            f"Zenoh support needs the zenoh extra: pip install -e '.[zenoh]' in the paramdds checkout ({exc})"
        ) from None
    return zenoh


def router_options(listen: Sequence[str], tls: TlsFiles | None = None) -> ZenohOptions:
    """A router session listening on ``listen`` (tests and small set-ups; production runs zenohd)."""
    return ZenohOptions(mode="router", listen=list(listen), tls=tls)


def remote_session(args: Any) -> Any:
    """The Zenoh session of the global ``--zenoh ENDPOINT``: a client. ``PARAMDDS_ZENOH_TLS``
    names a directory holding ``ca.pem``, ``cert.pem`` and ``key.pem`` (``paramdds zenoh
    --issue-cert`` writes one) for mutual TLS; ``PARAMDDS_ZENOH_CONFIG`` a JSON5 file for
    anything else."""
    import os

    config_file = os.environ.get("PARAMDDS_ZENOH_CONFIG", "").strip() or None
    tls_dir = os.environ.get("PARAMDDS_ZENOH_TLS", "").strip()
    tls = None
    if tls_dir:
        d = Path(tls_dir)
        tls = TlsFiles(str(d / "ca.pem"), str(d / "cert.pem"), str(d / "key.pem"))
    timeout = float(getattr(args, "timeout", 5.0))
    return open_session(
        ZenohOptions(
            mode="client", connect=[args.zenoh], config_file=config_file, tls=tls, open_timeout=timeout
        )
    )
