"""`stepramp expand`: the free curve equivalent to an init table."""

from __future__ import annotations

import argparse
from typing import Any

from ._common import EXIT_FINDINGS, EXIT_OK, refuse_table_errors


def add_subparser(sub: Any) -> None:
    x = sub.add_parser("expand", help="the free curve equivalent to an init table (the "
                                      "modelled staircase the chip builds)")
    x.add_argument("table", metavar="TABLE", help="an init table file")
    x.add_argument("-o", "--output", metavar="OUT",
                   help="write the free-curve table here (default stdout)")
    x.set_defaults(func=_do_expand)


def _do_expand(args: argparse.Namespace) -> int:
    from profiles.errors import FormatError
    from profiles.ppmc312.init_model import as_free_curve
    from profiles.ppmc312.table import FreeCurveTable, dump_table, load_table
    from verify.output import write_output

    table = load_table(args.table)
    if isinstance(table, FreeCurveTable):
        raise FormatError(f"{args.table}: already a free curve; expand takes an init table")
    # a table the chip refuses has no staircase: the same verdict as check and export
    if refuse_table_errors(args.table, table, "fix them (the chip refuses the table)"):
        return EXIT_FINDINGS
    write_output(args.output, dump_table(as_free_curve(table)))
    return EXIT_OK
