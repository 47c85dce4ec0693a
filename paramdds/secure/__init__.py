"""Secure mode: DDS Security (authentication, encryption, per-node permissions).

Everything secure lives in this package; the DDS layer has small hooks only:

* :mod:`.install` builds Cyclone DDS C with security from source and rebuilds the
  Python binding against it (the PyPI wheels have no security);
* :mod:`.keystore` makes the CAs, the governance and role identities with signed
  permissions (``paramdds keystore``);
* :mod:`.identity` reads one identity directory (``--identity`` /
  ``PARAMDDS_IDENTITY``) into the Cyclone ``<Security>`` configuration and its grants;
* :mod:`.scope` puts requests, replies and state into per-node partitions, and drops
  a sample whose ``node_id`` is not among its writer's partitions.

None of this imports cyclonedds at import time, so ``paramdds keystore`` and the
install run without a DDS library.
"""
