"""paramdds over Zenoh: a gateway per site, and a remote client and monitor (the ``zenoh`` extra).

* :mod:`.keys`: the key expressions (the wire contract, docs/zenoh.md);
* :mod:`.codec`: the JSON payloads (values, descriptors, node states, requests, replies);
* :mod:`.config`: Zenoh configurations from endpoints, modes, TLS files and JSON5 files;
* :mod:`.gateway`: one site's DDS domain published on Zenoh, calls forwarded to its nodes;
* :mod:`.remote`: :class:`~.remote.RemoteParameterClient` and
  :class:`~.remote.RemoteParameterMonitor`, the shapes of the DDS ones, nodes named
  ``SITE/NODE``.

Only this package imports ``zenoh``; nothing else of paramdds needs it.
"""
