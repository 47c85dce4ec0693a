"""Benchmarks (``paramdds bench SCENARIO``, whose arguments and scenario table are
:mod:`paramdds.cli.verbs.bench`): one module per scenario, each with ``run(args) -> int``.

Servers, echo peers and monitors run as separate processes; each scenario measures
paramdds and its baseline in the same run (docs/benchmarks.md).
"""

from __future__ import annotations

import argparse
import importlib


def run_scenario(scenario: str, args: argparse.Namespace) -> int:
    """Run the scenario module ``paramdds.bench.<scenario>``; its exit code."""
    from ._common import start_probe

    module = importlib.import_module(f"{__name__}.{scenario.replace('-', '_')}")
    start_probe()
    result: int = module.run(args)
    return result
