"""The ``polygen`` command line.

Each sub-command lives in the module of the wing it belongs to and
provides two functions: ``configure(parser)`` adds its arguments, and
``run(args) -> int`` does the work. They are imported lazily, so that
``polygen --help`` is quick and one broken wing does not break the others.
"""

import argparse
import importlib
import sys

# name -> (module, one-line help)
SUBCOMMANDS = {
    "datasets": ("polygen.volume._cli_datasets", "list and build the reproducible volume data sets"),
    "isosurface": ("polygen.volume._cli_isosurface", "extract isosurfaces from a volume, compared with VTK"),
}


def _available():
    out = {}
    for name, (module, help_) in SUBCOMMANDS.items():
        if importlib.util.find_spec(module) is not None:
            out[name] = (module, help_)
    return out


def build_parser():
    parser = argparse.ArgumentParser(prog="polygen", description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name, (module, help_) in _available().items():
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
