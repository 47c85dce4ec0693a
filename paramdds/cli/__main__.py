"""``python -m paramdds.cli``."""

from . import console

console()
