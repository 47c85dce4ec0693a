"""``python -m paramdds``: the ``paramdds`` command."""

from .cli import console

console()
