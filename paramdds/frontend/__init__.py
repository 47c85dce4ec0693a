"""What the front ends share (the ``paramdds`` command, the web console, the benchmarks).

The front ends (:mod:`paramdds.cli`, :mod:`paramdds.web`, :mod:`paramdds.bench`) never
import each other's modules (an import-linter contract, ``.importlinter``); what more
than one of them needs lives here, below them:

* :mod:`.exits`    exit codes and the one mapping from errors to them; ``UsageError``;
* :mod:`.session`  a command's DDS objects (participant, QoS, clients, monitors), made on
  first use and closed in order;
* :mod:`.shapes`   the JSON shapes of values and descriptors (pure);
* :mod:`.load`     loading a parameter file onto a node: only the values it changes are sent.

The parameter files (read, dump) are :mod:`paramdds.formats.files`; building and
running a server process is :mod:`paramdds.runtime`. Nothing here imports Cyclone at
import time.
"""
