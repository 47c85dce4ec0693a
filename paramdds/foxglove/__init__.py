"""paramdds foxglove: every node's parameters over the Foxglove WebSocket protocol (docs/foxglove.md)."""
