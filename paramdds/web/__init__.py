"""``paramdds web``: a live browser console for every node's parameters.

One process serves one page and a JSON API. State comes from one
:class:`~paramdds.dds.monitor.ParameterMonitor` (every node's current table,
online/offline, events); writes go through one
:class:`~paramdds.dds.client.ParameterClient` (bounded timeouts, atomic sets,
compare-and-set on the node's incarnation and revision). Updates reach the browser as
server-sent events, coalesced per subscriber, and only for what it shows.

Modules:

* :mod:`.status`  the one table from error codes to HTTP statuses;
* :mod:`.model`   JSON shapes of nodes, parameters (with their editor's choices) and events;
  typing of values sent by a browser;
* :mod:`.view`    the monitor's live state read under its lock, one page or one node at a time;
* :mod:`.hub`     monitor events → per-subscriber coalesced SSE batches;
* :mod:`.inputs`  query arguments and JSON bodies, read with a size cap;
* :mod:`.guard`   the Host check and security headers in front of every route;
* :mod:`.operator` the bearer tokens, and who a write is made as (a token's name, the page's, the console's);
* :mod:`.app`     the Starlette application (routes, the write checks);
* :mod:`.serve`   wiring monitor, client and uvicorn together (the CLI verb).

Needs the ``web`` extra (``pip install -e '.[web]'`` in the checkout, as docs/web.md says):
Starlette and uvicorn.
"""
