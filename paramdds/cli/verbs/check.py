"""``paramdds check``: parameter files against a JSON Schema or a spec, offline (no DDS).

It reads what ``server -p`` reads: ROS 2 parameter files and parameter lists (a list
applies to every node, so its findings are in section ``/**``). Exit 0 when every file
is valid, 1 when one is not (one line per error: file, node section, parameter path,
reason), 2 for input that cannot be used (an unreadable file, a broken schema, a
``$ref`` that fails when it is needed). ``--autoware DIR`` pairs
``<pkg>/schema/<name>.schema.json`` with ``<pkg>/config/<name>*.param.yaml`` as
Autoware's CI does and checks every pair.
"""

from __future__ import annotations

import argparse
import json
import sys
from typing import Any

HELP = "check parameter files against a JSON Schema (--schema, --autoware DIR) or a spec, offline"


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("files", nargs="*", metavar="PARAMS.yaml", help="parameter files to check")
    what = p.add_mutually_exclusive_group(required=True)
    what.add_argument("--schema", metavar="FILE", help="a JSON Schema (draft-07, Autoware's envelope)")
    what.add_argument("--spec", metavar="FILE", help="a generate_parameter_library spec")
    what.add_argument(
        "--autoware",
        metavar="DIR",
        help="every schema/<name>.schema.json under DIR with its config/<name>*.param.yaml",
    )
    p.add_argument(
        "--lenient", action="store_true", help="warn on unknown schema keywords instead of failing"
    )


def run(args: argparse.Namespace) -> int:
    from ...errors import ParamddsError
    from ...exits import Exit, UsageError
    from ...formats.schema import load_schema
    from ...formats.schema.check import Finding, autoware_pairs, check_with_schema, check_with_spec

    report: list[dict[str, Any]] = []
    worst = Exit.OK
    table = args.output == "table"

    def emit(file: str, schema: str, findings: list[Finding]) -> None:
        nonlocal worst
        report.append(
            {
                "file": file,
                "against": schema,
                "valid": not findings,
                "errors": [{"section": f.section, "path": f.path, "reason": f.reason} for f in findings],
            }
        )
        if findings:
            worst = max(worst, Exit.REFUSED)
        if table:
            lines = [str(f) for f in findings] or [f"{file}: ok"]
            sys.stdout.write("".join(line + "\n" for line in lines))

    def broken(file: str, schema: str, exc: ParamddsError) -> None:
        nonlocal worst
        worst = Exit.USAGE
        report.append({"file": file, "against": schema, "valid": False, "unusable": str(exc)})
        if table:
            sys.stderr.write(f"paramdds: error: {exc}\n")

    if args.autoware:
        if args.files:
            raise UsageError("--autoware finds the files itself: give no PARAMS.yaml")
        pairs = autoware_pairs(args.autoware)
        if not pairs:
            raise UsageError(f"--autoware {args.autoware}: no schema/<name>.schema.json under it")
        for schema_path, params in pairs:
            if not params and table:
                name = schema_path.name[: -len(".schema.json")]
                sys.stdout.write(
                    f"{schema_path}: no config/{name}*.param.yaml beside it (nothing to check)\n"
                )
            for path in params:
                try:
                    schema = load_schema(schema_path, lenient=args.lenient, declare=False)
                    emit(str(path), str(schema_path), check_with_schema(schema, path))
                except ParamddsError as exc:
                    broken(str(path), str(schema_path), exc)
    else:
        if not args.files:
            raise UsageError("give the parameter files to check (or --autoware DIR)")
        if args.schema:
            against = args.schema
            schema = load_schema(args.schema, lenient=args.lenient, declare=False)

            def check(path: str) -> list[Finding]:
                return check_with_schema(schema, path)

        else:
            from ...formats.spec import load_spec

            against = args.spec
            spec = load_spec(args.spec)

            def check(path: str) -> list[Finding]:
                return check_with_spec(spec, path)

        for path in args.files:
            try:
                emit(path, against, check(path))
            except ParamddsError as exc:
                broken(path, against, exc)
    if not table:
        sys.stdout.write(json.dumps(report, indent=2) + "\n")
    sys.stdout.flush()
    return int(worst)
