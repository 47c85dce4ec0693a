"""Secure mode: DDS Security (authentication, encryption, per-node permissions).

What secure mode needs besides the transport lives in this package; the per-node
partitions and the writer-partition check are the secure form of the transport
(:mod:`paramdds.dds.transport`), which gets an identity as plain data:

* :mod:`.install` builds Cyclone DDS C with security from source and rebuilds the
  Python binding against it (the PyPI wheels have no security);
* :mod:`.keystore` makes the CAs, the governance and role identities with signed
  permissions (``paramdds keystore``);
* :mod:`.identity` reads one identity directory (``--identity`` /
  ``PARAMDDS_IDENTITY``) into the Cyclone ``<Security>`` configuration and its grants.
* :mod:`.authenticated` tells a server the certificate subject of a request's writer
  (``ParameterServer.authenticate``): who made a change, verified.

None of this imports cyclonedds at import time, so ``paramdds keystore`` and the
install run without a DDS library.
"""
