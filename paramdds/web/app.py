"""The Starlette application: the page, the JSON API and the event stream.

Routes (all JSON unless said; writes take a JSON body and are absent with --read-only):

=======  =================  ==========================================================
GET      /                  the console page (static files under /static/)
GET      /api/info          ``{"read_only", "token_required", "domain", "zenoh"}``
GET      /api/nodes         ``?q=&offset=&limit=`` → ``{"total", "offset", "nodes": [summary],
                            "missing": [{"site", "status", "reason"}]}`` (``missing`` over Zenoh
                            only: the known sites lacking, every one on every page)
GET      /api/node          ``?node=`` → ``{"summary", "rows": [row]}``
GET      /api/dump          ``?node=&descriptors=0|1`` → a ROS 2 parameter file (text/yaml)
GET      /api/history       ``?node=&name=&since=&until=&who=&outcome=&limit=`` → ``{"node", "names",
                            "kept", "compacted", "more", "records": [record]}``, newest first
GET      /api/events        ``?node=`` → server-sent events: node, params, nodes, log, resync
GET      /api/openapi.json  the OpenAPI schema of these routes
POST     /api/validate      ``{"node", "values": {name: value}}`` → ``{"node", "results": [{"name",
                            "valid", "reason", "code"}]}`` (checks only; sends nothing)
POST     /api/set           ``{"node", "values": {name: value}, "atomic", "if_revision", "as"}``
POST     /api/delete        ``{"node", "names": [name], "as"}``
POST     /api/load          ``{"node", "text", "atomic", "as"}`` (the text of a parameter file)
=======  =================  ==========================================================

Safety, checked before a route runs: the ``Host`` header must name this server
(a DNS-rebinding page cannot read or write); a write must come from this origin
(``Origin``/``Sec-Fetch-Site``), carry ``Content-Type: application/json``, the
bearer token when one is configured, and a body of at most :data:`.inputs.MAX_BODY`
bytes. Every error is a JSON body with a code; its status comes from
:data:`paramdds.web.status.STATUS`. A write is made as its operator (``"as"``, or the
name its token carries: :mod:`.operator`) through ``web``.
"""

from __future__ import annotations

import logging
from collections.abc import AsyncIterator
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any
from urllib.parse import unquote

from starlette.applications import Starlette
from starlette.exceptions import HTTPException
from starlette.requests import Request
from starlette.responses import FileResponse, JSONResponse, PlainTextResponse, Response, StreamingResponse
from starlette.routing import Mount, Route
from starlette.schemas import SchemaGenerator
from starlette.staticfiles import StaticFiles
from starlette.types import ASGIApp

from ..core.names import validate_name
from ..core.revision import Revision, incarnation_text
from ..core.values import NOT_SET, Parameter
from ..errors import ErrorCode, FileFormatError, NoHistoryError, ParamddsError
from ..file_load import unchanged as unchanged_value
from ..listen import LOOPBACK_NAMES, Token, matching
from .guard import Guard, error_response
from .hub import Hub, sse
from .inputs import (
    bool_field,
    file_entries,
    int_arg,
    names_arg,
    node_arg,
    outcome_arg,
    read_body,
    revision_field,
    since_arg,
    time_arg,
)
from .model import (
    Row,
    atomic_refusal,
    checked,
    history_row,
    parameter_row,
    refused_row,
    result_row,
    summary_json,
    typed_parameters,
)
from .operator import claimed_name, operator
from .status import WebCode, WebError, code_of, error_body, status_of
from .view import NodeDetail, StateView

if TYPE_CHECKING:
    from ..core.replies import SetReply
    from ..dds.client import AsyncParameterClient

log = logging.getLogger(__name__)

PAGE_LIMIT = 200  # nodes per page at most
TOKEN_COOKIE = "paramdds-token"  # set by the page where reads need the token (see Console._check_read)
KEEPALIVE = 15.0  # seconds between comments on an idle event stream
HISTORY_LIMIT = 200  # records a history answer holds unless asked for more
MAX_HISTORY = 10_000  # records a history answer may hold at most (a node keeps 10,000 by default)


@dataclass(frozen=True)
class WebOptions:
    read_only: bool = False
    tokens: tuple[Token, ...] = ()  # --token-file: the bearer tokens accepted, each maybe naming its operator
    domain: int = 0
    zenoh: str | None = None  # the router's endpoint when the console reaches sites over Zenoh
    allowed_hosts: tuple[str, ...] = LOOPBACK_NAMES  # the Host names accepted (DNS rebinding)
    timeout: float = 5.0
    token_for_reads: bool = False  # a bind other machines reach: reads need the token as well
    schemas: tuple[tuple[str, Any], ...] = ()  # --schema NODE=FILE: (node, NodeSchema) checked before a write


# -- errors ------------------------------------------------------------------------------


async def _paramdds_error(_request: Request, exc: Exception) -> Response:
    assert isinstance(exc, ParamddsError)
    return error_response(code_of(exc), exc.message)


async def _http_error(_request: Request, exc: Exception) -> Response:
    assert isinstance(exc, HTTPException)
    code = {404: ErrorCode.NOT_FOUND.value, 405: "METHOD_NOT_ALLOWED"}.get(exc.status_code, "HTTP_ERROR")
    return JSONResponse(error_body(code, str(exc.detail)), status_code=exc.status_code)


async def _internal_error(_request: Request, exc: Exception) -> Response:
    log.error("internal error in the web console", exc_info=exc)
    return JSONResponse(error_body("INTERNAL", "internal error (see the server's log)"), status_code=500)


# -- input -------------------------------------------------------------------------------


def _bearer(request: Request) -> str:
    """The token of an ``Authorization: Bearer TOKEN`` header, "" without one."""
    scheme, _, value = request.headers.get("authorization", "").partition(" ")
    return value.strip() if scheme.lower() == "bearer" else ""


# -- the app -----------------------------------------------------------------------------


class Console:
    """The routes, over one state view, one hub and one client."""

    def __init__(self, view: StateView, hub: Hub, client: AsyncParameterClient, options: WebOptions) -> None:
        self.view = view
        self.hub = hub
        self.client = client  # set, delete
        self.options = options

    def _detail(self, node: str) -> NodeDetail:
        detail = self.view.detail(node)
        if detail is None:
            raise WebError(ErrorCode.NOT_FOUND, f"node {node!r} is unknown to this console")
        return detail

    def _online(self, node: str) -> NodeDetail:
        """The node to write to; UNAVAILABLE at once when this console sees it offline (its
        server stopped, or was killed and its liveliness lease ran out), instead of
        sending a request that only a timeout would end."""
        detail = self._detail(node)
        if not detail.summary.online:
            raise WebError(ErrorCode.UNAVAILABLE, f"node {node!r} is offline (its server is not running)")
        return detail

    @staticmethod
    def _rows(detail: NodeDetail) -> list[Row]:
        last = detail.last_changes
        return [parameter_row(n, v, d, last.get(n)) for n, (v, d) in sorted(detail.parameters.items())]

    # -- reads ------------------------------------------------------------------------------

    async def info(self, _request: Request) -> Response:
        """What this console allows.
        ---
        summary: The console's options
        responses:
          200: {description: '{"read_only": bool, "token_required": bool, "domain": int, "zenoh": str|null}'}
        """
        o = self.options
        return JSONResponse(
            {
                "read_only": o.read_only,
                "token_required": bool(o.tokens),
                "token_for_reads": o.token_for_reads,
                "domain": o.domain,
                "zenoh": o.zenoh,
            }
        )

    def _check_read(self, request: Request) -> None:
        """On a bind other machines reach, reads need the token too: the ``Authorization``
        header, or the ``paramdds-token`` cookie the page sets (an EventSource and a download
        link send no header). The cookie is SameSite=Strict; writes still need the header."""
        if not self.options.token_for_reads or not self.options.tokens:
            return
        given = _bearer(request) or unquote(request.cookies.get(TOKEN_COOKIE, ""))
        if matching(self.options.tokens, given) is None:
            raise WebError(WebCode.UNAUTHORIZED, "this console needs the bearer token (reads too)")

    async def nodes(self, request: Request) -> Response:
        """One page of the node list.
        ---
        summary: One page of the node list, filtered
        parameters:
          - {name: q, in: query, schema: {type: string}, description: part of a node id or a name}
          - {name: offset, in: query, schema: {type: integer, minimum: 0, default: 0}}
          - {name: limit, in: query, schema: {type: integer, minimum: 1, maximum: 200, default: 50}}
        responses:
          200: {description: '{"total", "offset", "nodes": [summary], "missing" (Zenoh): [{"site", ...}]}'}
          400: {description: BAD_REQUEST}
        """
        self._check_read(request)
        query = request.query_params.get("q", "")[:200]
        offset = int_arg(request, "offset", 0, 0, 10**9)
        limit = int_arg(request, "limit", 50, 1, PAGE_LIMIT)
        page = self.view.page(query, offset, limit)
        body = {"total": page.total, "offset": page.offset, "nodes": [summary_json(s) for s in page.nodes]}
        if self.view.follows_sites:  # over Zenoh: the sites lacking, whatever the query and page
            body["missing"] = self.view.lacking()
        return JSONResponse(body)

    async def node(self, request: Request) -> Response:
        """One node's parameters with descriptors.
        ---
        summary: A node's summary and parameter rows
        parameters:
          - {name: node, in: query, required: true, schema: {type: string}}
        responses:
          200: {description: '{"summary", "rows": [{"name", "value", "type", "descriptor", "choices"}]}'}
          404: {description: NOT_FOUND (unknown node)}
        """
        self._check_read(request)
        detail = self._detail(node_arg(request.query_params.get("node")))
        return JSONResponse({"summary": summary_json(detail.summary), "rows": self._rows(detail)})

    async def dump(self, request: Request) -> Response:
        """A node as a parameter file.
        ---
        summary: A node as a ROS 2 parameter file (text/yaml attachment)
        parameters:
          - {name: node, in: query, required: true, schema: {type: string}}
          - {name: descriptors, in: query, schema: {type: integer, enum: [0, 1], default: 1}}
        responses:
          200: {description: the file}
          404: {description: NOT_FOUND}
        """
        from ..formats.files import dump_text

        self._check_read(request)
        node = node_arg(request.query_params.get("node"))
        detail = self._detail(node)
        with_descriptors = request.query_params.get("descriptors", "1") != "0"
        snapshot = [(n, v, d) for n, (v, d) in sorted(detail.parameters.items())]
        text = dump_text({node: snapshot}, with_descriptors=with_descriptors)
        filename = node.replace("/", "_") + ".yaml"
        return PlainTextResponse(
            text,
            media_type="text/yaml",
            headers={"Content-Disposition": f'attachment; filename="{filename}"'},
        )

    async def history(self, request: Request) -> Response:
        """A node's past, newest first: the changes it applied and the writes it refused.
        ---
        summary: A node's history (its parameters' timelines), newest first
        parameters:
          - {name: node, in: query, required: true, schema: {type: string}}
          - {name: name, in: query, schema: {type: string}, description: 'a name (repeatable; none: all)'}
          - {name: since, in: query, schema: {type: string}, description: 'a revision or an ISO 8601 time'}
          - {name: until, in: query, schema: {type: string}, description: an ISO 8601 time}
          - {name: who, in: query, schema: {type: string}, description: 'a glob on who (alice, *@robot1)'}
          - {name: outcome, in: query, schema: {type: string, enum: [all, applied, refused], default: all}}
          - {name: limit, in: query, schema: {type: integer, minimum: 1, maximum: 10000, default: 200}}
        responses:
          200: {description: '{"node", "names", "kept", "compacted", "more", "records": [record]}'}
          400: {description: BAD_REQUEST (a malformed since, until, outcome or limit)}
          404: {description: NOT_FOUND (unknown node)}
          503: {description: UNAVAILABLE (node offline)}
        """
        self._check_read(request)
        node = node_arg(request.query_params.get("node"))
        names = names_arg(request)
        since_revision, since_time = since_arg(request)
        until = time_arg(request, "until")
        who = request.query_params.get("who", "")[:200]
        outcome = outcome_arg(request)
        limit = int_arg(request, "limit", HISTORY_LIMIT, 1, MAX_HISTORY)
        self._online(node)
        body: dict[str, object] = {"node": node, "names": list(names)}
        try:
            reply = await self.client.history(
                node,
                names,
                since_revision=since_revision,
                since_time=since_time,
                until=until,
                who=who,
                outcome=outcome,
                timeout=self.options.timeout,
            )
        except NoHistoryError:  # a node of an older release, or a foreign peer: it keeps none
            return JSONResponse({**body, "kept": False, "compacted": False, "more": False, "records": []})
        newest = list(reversed(reply.records))
        return JSONResponse(
            {
                **body,
                "kept": True,
                "compacted": reply.compacted,
                "more": len(newest) > limit,
                "records": [history_row(r) for r in newest[:limit]],
            }
        )

    async def events(self, request: Request) -> Response:
        """The live event stream.
        ---
        summary: 'Server-sent events: node, params, nodes, log, resync'
        parameters:
          - {name: node, in: query, schema: {type: string}, description: the node whose rows are sent}
        responses:
          200: {description: text/event-stream}
        """
        self._check_read(request)
        raw = request.query_params.get("node", "")
        node = node_arg(raw) if raw else ""
        sub = self.hub.subscribe(node)

        async def stream() -> AsyncIterator[str]:
            import asyncio

            try:
                yield "retry: 1000\n\n"
                if node:
                    detail = self.view.detail(node)
                    yield sse(
                        "node",
                        {
                            "node": node,
                            "summary": summary_json(detail.summary) if detail else None,
                            "rows": self._rows(detail) if detail else [],
                        },
                    )
                while True:
                    try:
                        message = await asyncio.wait_for(sub.queue.get(), KEEPALIVE)
                    except TimeoutError:
                        yield ": keepalive\n\n"
                        continue
                    if message is None:
                        return
                    yield message
            finally:
                self.hub.unsubscribe(sub)

        return StreamingResponse(
            stream(),
            media_type="text/event-stream",
            headers={"Cache-Control": "no-store", "X-Accel-Buffering": "no"},
        )

    async def validate(self, request: Request) -> Response:
        """Validate values as the node would, sending nothing: the page asks it as the user edits.
        ---
        summary: 'Validate values without setting them: {"node", "values": {name: value}}'
        requestBody: {required: true, content: {application/json: {}}}
        responses:
          200: {description: '{"node", "results": [{"name", "valid", "reason", "code"}]}'}
          400: {description: BAD_REQUEST}
          404: {description: NOT_FOUND (unknown node)}
        """
        self._check_read(request)
        body = await read_body(request)
        node = node_arg(body.get("node"))
        values = body.get("values")
        if not isinstance(values, dict) or not values:
            raise WebError(WebCode.BAD_REQUEST, "'values' must be a non-empty object of name: value")
        detail = self._detail(node)
        typed, unfit = typed_parameters(values, detail.parameters)
        unfit += self._precheck(node, detail, typed, False)[1]  # --schema NODE=FILE
        refused: dict[str, Row] = {str(r["name"]): {"reason": r["reason"], "code": r["code"]} for r in unfit}
        valid: Row = {"reason": "", "code": None}
        results = [{"name": n, "valid": n not in refused, **refused.get(n, valid)} for n in values]
        return JSONResponse({"node": node, "results": results})

    # -- writes -----------------------------------------------------------------------------

    def _check_write(self, request: Request) -> Token | None:
        """Refuses a write from another origin or without the token; the token it carries."""
        origin = request.headers.get("origin")
        host = request.headers.get("host", "")
        if origin is not None and origin != f"{request.url.scheme}://{host}":
            raise WebError(WebCode.CROSS_ORIGIN, f"a write from origin {origin[:100]!r} is refused")
        if request.headers.get("sec-fetch-site", "same-origin") not in ("same-origin", "none"):
            raise WebError(WebCode.CROSS_ORIGIN, "a write from another site is refused")
        if not self.options.tokens:
            return None
        token = matching(self.options.tokens, _bearer(request))
        if token is None:
            raise WebError(WebCode.UNAUTHORIZED, "this console needs the bearer token for writes")
        return token

    async def _write_request(self, request: Request) -> tuple[dict[str, Any], str, str]:
        """A write's JSON body, its node and who it is made as (:func:`.operator.operator`),
        once the write is allowed (checked before reading)."""
        token = self._check_write(request)
        body = await read_body(request)
        who = operator(token, claimed_name(body), self.client.sync.who)  # the client's: --as, or its default
        return body, node_arg(body.get("node")), who

    async def _send(
        self,
        node: str,
        params: list[Parameter],
        who: str,
        *,
        atomic: bool = False,
        if_revision: int | Revision | None = None,
    ) -> SetReply:
        """One write to the node, made as ``who`` (through ``web``: the console's client's channel)."""
        timeout = self.options.timeout
        return await self.client.set(
            node, params, atomic=atomic, if_revision=if_revision, timeout=timeout, as_=who
        )

    async def set(self, request: Request) -> Response:
        """Set parameters (plain or atomic, optionally compare-and-set).
        ---
        summary: 'Set parameters: {"node", "values": {name: value}, "atomic", "if_revision"}'
        requestBody: {required: true, content: {application/json: {}}}
        responses:
          200: {description: '{"node", "revision", "results": [{"name", "successful", "reason", "code"}]}'}
          400: {description: BAD_REQUEST}
          401: {description: UNAUTHORIZED}
          403: {description: READ_ONLY or CROSS_ORIGIN}
          404: {description: NOT_FOUND}
          409: {description: CONFLICT (with the current summary and rows), or EXPIRED (nothing applied)}
          413: {description: TOO_LARGE}
          415: {description: UNSUPPORTED_MEDIA}
          422: {description: TYPE_MISMATCH, OUT_OF_RANGE, INVALID_VALUE, INVALID_NAME}
          503: {description: UNAVAILABLE (not sent)}
          504: {description: 'OUTCOME_UNKNOWN: sent, not answered in time; it may have been applied'}
        """
        body, node, who = await self._write_request(request)
        values = body.get("values")
        if not isinstance(values, dict) or not values:
            raise WebError(WebCode.BAD_REQUEST, "'values' must be a non-empty object of name: value")
        atomic = bool_field(body, "atomic")
        if_revision = revision_field(body)
        detail = self._online(node)
        params, refused = typed_parameters(values, detail.parameters)
        if not (refused and atomic):
            params, unfit = self._precheck(node, detail, params, atomic)
            refused += unfit
        if refused and atomic:  # nothing is sent: each row says why, as the node's would
            rows = atomic_refusal(values, _in_order(values, refused))
            return self._set_response(node, detail.summary.at, rows, atomic, who)
        if not params:
            return self._set_response(node, detail.summary.at, _in_order(values, refused), who=who)
        reply = await self._send(node, params, who, atomic=atomic, if_revision=if_revision)
        rows = _in_order(values, [result_row(r) for r in reply.results] + refused)
        return self._set_response(node, reply.at, rows, atomic, who)

    def _precheck(
        self, node: str, detail: NodeDetail, params: list[Parameter], atomic: bool
    ) -> tuple[list[Parameter], list[Row]]:
        """--schema NODE=FILE: what the node's schema lets through, and the rows of the rest."""
        schema = dict(self.options.schemas).get(node)
        if schema is None:
            return params, []
        from .schema_guard import precheck

        return precheck(schema, detail.parameters, params, atomic)

    async def delete(self, request: Request) -> Response:
        """Delete parameters.
        ---
        summary: 'Delete parameters: {"node", "names": [name]}'
        requestBody: {required: true, content: {application/json: {}}}
        responses:
          200: {description: '{"node", "revision", "results"}'}
        """
        body, node, who = await self._write_request(request)
        names = body.get("names")
        if not isinstance(names, list) or not names or not all(isinstance(n, str) for n in names):
            raise WebError(WebCode.BAD_REQUEST, "'names' must be a non-empty list of strings")
        detail = self._online(node)
        asked = dict.fromkeys(names)
        refused: list[Row] = []
        for n in asked:
            try:
                validate_name(n)
            except ParamddsError as exc:
                refused.append(refused_row(n, exc.message, code_of(exc)))
        named = [Parameter(n, NOT_SET) for n in asked if all(r["name"] != n for r in refused)]
        deletes, unfit = self._precheck(node, detail, named, False)
        refused += unfit
        if not deletes:
            return self._set_response(node, detail.summary.at, _in_order(asked, refused), who=who)
        reply = await self._send(node, deletes, who)
        rows = _in_order(asked, [result_row(r) for r in reply.results] + refused)
        return self._set_response(node, reply.at, rows, who=who)

    async def load(self, request: Request) -> Response:
        """Set a node's parameters from the text of a parameter file.
        ---
        summary: 'Load a parameter file: {"node", "text", "atomic"}'
        requestBody: {required: true, content: {application/json: {}}}
        responses:
          200: {description: '{"node", "revision", "results"}, one result per parameter'}
          422: {description: FILE_FORMAT (with file and line) or a refused value}
        """
        body, node, who = await self._write_request(request)
        text = body.get("text")
        if not isinstance(text, str) or not text.strip():
            raise WebError(WebCode.BAD_REQUEST, "'text' must be the non-empty text of a parameter file")
        atomic = bool_field(body, "atomic")
        detail = self._online(node)
        entries = file_entries(text, node)
        if not entries:
            raise FileFormatError(f"no parameters for node {node!r} in this file", file="upload")
        sendable: list[Parameter] = []
        refused: list[Row] = []
        unchanged: list[Row] = []
        for name, value, _ in entries:
            described = detail.parameters.get(name)
            if described is not None and unchanged_value(name, value, *described):
                # not a change (a node's own dump holds its read-only parameters too): not sent
                unchanged.append({"name": name, "successful": True, "reason": "unchanged", "code": None})
                continue
            try:
                sendable.append(Parameter(name, checked(name, value, described[1] if described else None)))
            except ParamddsError as exc:
                refused.append(refused_row(name, exc.message, code_of(exc)))
        sendable, unfit = self._precheck(node, detail, sendable, atomic)
        refused += unfit
        if refused and atomic:
            rows = atomic_refusal([name for name, _, _ in entries], refused + unchanged)
            return self._set_response(node, detail.summary.at, rows, atomic, who)
        results: list[Row] = refused + unchanged
        at = detail.summary.at
        if sendable:
            reply = await self._send(node, sendable, who, atomic=atomic)
            results = [result_row(r) for r in reply.results] + results
            at = reply.at
        return self._set_response(node, at, results, atomic, who)

    def _set_response(
        self, node: str, at: Revision, results: list[Row], atomic: bool = False, who: str = ""
    ) -> Response:
        """A write's answer (``who``: the operator it was made as); refused, its status is the
        first refusal's code, or for an atomic write its cause's (the first code other than the
        INVALID_VALUE of "not applied")."""
        body: dict[str, object] = {
            "node": node,
            "revision": at.revision,
            "incarnation": incarnation_text(at.incarnation),
            "who": who,
            "results": results,
        }
        failed = [r for r in results if not r["successful"]]
        if not failed:
            return JSONResponse(body)
        invalid = ErrorCode.INVALID_VALUE.value
        codes = [str(r["code"] or invalid) for r in failed]
        code = next((c for c in codes if c != invalid), invalid) if atomic else codes[0]
        why = "; ".join(f"{r['name']}: {r['reason']}" for r in failed)  # as the CLI words it
        message = f"{len(failed)} of {len(results)} parameters refused by node {node!r}: {why}"
        body.update(error_body(code, message))
        if code == ErrorCode.CONFLICT.value:
            detail = self.view.detail(node)  # the newer values the page shows instead of overwriting
            if detail is not None:
                body["summary"] = summary_json(detail.summary)
                body["rows"] = self._rows(detail)
        return JSONResponse(body, status_code=status_of(code))


def _in_order(requested: dict[str, Any], rows: list[Row]) -> list[Row]:
    order = {name: i for i, name in enumerate(requested)}
    return sorted(rows, key=lambda r: order.get(str(r["name"]), len(order)))


def build_app(view: StateView, hub: Hub, client: AsyncParameterClient, options: WebOptions) -> ASGIApp:
    """The whole application, wrapped in the Host/header guard."""
    from importlib.resources import files

    console = Console(view, hub, client, options)
    index = str(files("paramdds.web") / "static" / "index.html")
    icon = str(files("paramdds.web") / "static" / "favicon.svg")

    async def page(_request: Request) -> Response:
        return FileResponse(index, media_type="text/html", headers={"Cache-Control": "no-store"})

    from importlib.metadata import version

    schemas = SchemaGenerator(
        {"openapi": "3.0.0", "info": {"title": "paramdds web console", "version": version("paramdds")}}
    )

    async def openapi(request: Request) -> Response:
        return JSONResponse(schemas.get_schema(routes=request.app.routes))

    async def favicon(_request: Request) -> Response:
        return FileResponse(icon, media_type="image/svg+xml", headers={"Cache-Control": "max-age=86400"})

    routes = [
        Route("/", page, include_in_schema=False),
        Route("/favicon.ico", favicon, include_in_schema=False),  # browsers ask for it on every load
        Route("/api/openapi.json", openapi, include_in_schema=False),
        Route("/api/info", console.info),
        Route("/api/nodes", console.nodes),
        Route("/api/node", console.node),
        Route("/api/dump", console.dump),
        Route("/api/history", console.history),
        Route("/api/events", console.events),
        Route("/api/validate", console.validate, methods=["POST"]),
        Mount("/static", StaticFiles(packages=[("paramdds.web", "static")]), name="static"),
    ]
    if not options.read_only:
        routes += [
            Route("/api/set", console.set, methods=["POST"]),
            Route("/api/delete", console.delete, methods=["POST"]),
            Route("/api/load", console.load, methods=["POST"]),
        ]
    app = Starlette(
        routes=routes,
        exception_handlers={
            ParamddsError: _paramdds_error,
            HTTPException: _http_error,
            Exception: _internal_error,
        },
    )
    return Guard(app, options.allowed_hosts)
