"""The ``polygen`` command line.

Each sub-command is a module of this package (as meshio keeps its ``_cli/``
beside the formats) with two functions: ``configure(parser)`` adds its
arguments, and ``run(args) -> int`` does the work. Nothing in the algorithm
packages imports the CLI.
"""

import argparse
import importlib
import sys

# name -> (module, one-line help)
SUBCOMMANDS = {
    "datasets": ("polygen.cli.datasets", "list and build the reproducible volume data sets"),
    "isosurface": ("polygen.cli.isosurface", "extract isosurfaces from a volume, compared with VTK"),
}


def build_parser():
    parser = argparse.ArgumentParser(prog="polygen", description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name, (module, help_) in SUBCOMMANDS.items():
        p = sub.add_parser(name, help=help_, description=help_)
        importlib.import_module(module).configure(p)
        p.set_defaults(_module=module)
    return parser


def main(argv=None):
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.command is None:
        parser.print_help()
        return 2
    return int(importlib.import_module(args._module).run(args) or 0)


if __name__ == "__main__":
    sys.exit(main())
