"""paramdds record: every change of the matching nodes, with its author, into an MCAP file.

:mod:`.serve` runs a recording (the monitor, the signals, the loop), :mod:`.tracker` turns
monitor events into the recording's messages, each once (revisions the monitor skipped
filled from the node's history, or recorded as a gap), :mod:`.mcapfile` writes the files
(chunks closed on time, ``--split``). The format itself is :mod:`paramdds.formats.recording`'s.
"""
