"""paramdds record: every change of the matching nodes, with its author, into an MCAP file."""
