"""paramdds over Zenoh: a gateway per site, and a remote client and monitor (the ``zenoh`` extra).

* :mod:`.keys`: the key expressions (the wire contract, docs/zenoh.md);
* :mod:`.codec`: the JSON payloads (values, descriptors, node states with their last
  changes, requests, replies); :mod:`.history`: those of history queries and pages;
* :mod:`.config`: Zenoh configurations from endpoints, modes, TLS files and JSON5 files;
* :mod:`.gateway`: one site's DDS domain published on Zenoh, calls forwarded to its nodes;
* :mod:`.client`: :func:`~.client.RemoteParameterClient`, the one
  :class:`~paramdds.dds.client.ParameterClient` over a Zenoh transport, nodes named ``SITE/NODE``;
* :mod:`.monitor`: :class:`~.monitor.RemoteParameterMonitor`, the one
  :class:`~paramdds.dds.monitor.ParameterMonitor` over a Zenoh feed;
* :mod:`.states`: the gateways' node states, which both query.

Only this package imports ``zenoh``; nothing else of paramdds needs it.
"""
