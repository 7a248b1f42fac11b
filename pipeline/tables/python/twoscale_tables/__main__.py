"""python -m twoscale_tables lookup FILE.h5 NAME=VALUE ...

Prints {"table": ..., "values": {...}}, the JSON of `twoscale lookup --json`. Exit status: 0;
1, an unreadable or corrupt table (one line on stderr); 2, bad usage or a bad point.
"""
import json
import sys

from . import Table

USAGE = "usage: python -m twoscale_tables lookup FILE.h5 NAME=VALUE ..."


def main(argv=None):
    """The command line on `argv` (argv[0] the program's name); returns the exit status."""
    argv = sys.argv if argv is None else argv
    if len(argv) < 3 or argv[1] != "lookup":
        print(USAGE, file=sys.stderr)
        return 2
    try:
        table = Table.open(argv[2])
    except Exception as e:  # any failure to read the table: one line, exit 1
        print(f"twoscale_tables: error: {e}".replace("\n", " "), file=sys.stderr)
        return 1
    try:
        point = {}
        for item in argv[3:]:
            name, _, value = item.partition("=")
            point[name] = float(value)
        values = table.lookup(point)
    except (ValueError, KeyError) as e:
        print(f"twoscale_tables: error: {e}", file=sys.stderr)
        return 2
    print(json.dumps({"table": table.manifest["table"], "values": values}))
    return 0


if __name__ == "__main__":
    sys.exit(main())
