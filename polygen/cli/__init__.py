"""The ``polygen`` command line.

Each sub-command is a module of this package (as meshio keeps its ``_cli/``
beside the formats) with two functions: ``configure(parser)`` adds its
arguments, and ``run(args) -> int`` does the work; a module may also give
``EXAMPLES``, shown at the end of its ``--help``. Nothing in the algorithm
packages imports the CLI.

Errors speak to people: a bad input (a file that is no volume mesh, an
unknown field or method, inverted cells, ...) prints one line,
``polygen COMMAND: what is wrong``, on stderr and exits with status 2; any
other failure prints one line and exits with status 1. ``--debug`` shows
the Python traceback instead, and VTK's own log, which otherwise never
reaches the terminal. Files a command will write are checked before it
starts its work. A closed pipe (``polygen datasets | head``)
ends the command quietly.
"""

import argparse
import contextlib
import importlib
import os
import sys
import warnings

# name -> (module, one-line help)
SUBCOMMANDS = {
    "datasets": ("polygen.cli.datasets", "list and build the reproducible volume data sets"),
    "isosurface": ("polygen.cli.isosurface", "extract isosurfaces from a volume, compared with VTK"),
}

#: exit status of a bad input (as argparse's own usage errors)
EXIT_INPUT = 2
#: exit status of any other failure
EXIT_FAILURE = 1


class CLIError(ValueError):
    """A bad input to a command; ``main`` prints its message in one line and exits with status 2."""


def _input_errors():
    from polygen.volume import VolumeError
    from polygen.volume.surface import IsoSurfaceError

    return (CLIError, VolumeError, IsoSurfaceError)


def build_parser():
    parser = argparse.ArgumentParser(prog="polygen", description=__doc__.splitlines()[0])
    parser.add_argument("--debug", action="store_true", help="show Python tracebacks of errors")
    common = argparse.ArgumentParser(add_help=False)
    # SUPPRESS: 'polygen --debug isosurface' is not undone by the sub-command's default
    common.add_argument("--debug", action="store_true", default=argparse.SUPPRESS,
                        help="show the Python traceback of an error instead of one line")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name, (module, help_) in SUBCOMMANDS.items():
        mod = importlib.import_module(module)
        p = sub.add_parser(name, help=help_, description=help_, parents=[common],
                           epilog=getattr(mod, "EXAMPLES", None),
                           formatter_class=argparse.RawDescriptionHelpFormatter)
        mod.configure(p)
        p.set_defaults(_module=module)
    return parser


def _one_line(exc):
    text = " ".join(str(exc).split())
    return text or type(exc).__name__


def _stdout_gone():
    """stdout's reader left (``| head``): point stdout at the null device so that the flush at exit is quiet."""
    try:
        null = os.open(os.devnull, os.O_WRONLY)
        os.dup2(null, sys.stdout.fileno())
        os.close(null)
    except (OSError, ValueError):
        pass


@contextlib.contextmanager
def _quiet_vtk(quiet):
    """VTK's error log (a writer's, a reader's) off the terminal while the command runs: it says what failed
    in one line. VTK's settings are process-wide, so they are put back after (``main`` called from Python,
    e.g. by the tests, must not change how VTK reports errors to later work in the process)."""
    try:
        from vtkmodules.vtkCommonCore import vtkLogger, vtkObject
    except ImportError:  # pragma: no cover - pyvista brings VTK
        quiet = False
    if not quiet:
        yield
        return
    # (vtkLogger has no getter for the stderr sink alone: the cutoff over its sinks is that one by default)
    display, verbosity = vtkObject.GetGlobalWarningDisplay(), vtkLogger.GetCurrentVerbosityCutoff()
    vtkObject.GlobalWarningDisplayOff()
    vtkLogger.SetStderrVerbosity(vtkLogger.VERBOSITY_OFF)
    try:
        yield
    finally:
        vtkObject.SetGlobalWarningDisplay(display)
        vtkLogger.SetStderrVerbosity(verbosity)


def main(argv=None):
    parser = build_parser()
    args = parser.parse_args(argv)
    if args.command is None:
        parser.print_help()
        return EXIT_INPUT
    prog = f"polygen {args.command}"
    with warnings.catch_warnings(), _quiet_vtk(not args.debug):
        if not args.debug:  # warnings in one line, as errors; VTK's log only with --debug
            warnings.showwarning = lambda message, *rest, **kw: print(f"{prog}: warning: {_one_line(message)}",
                                                                      file=sys.stderr)
        try:
            return int(importlib.import_module(args._module).run(args) or 0)
        except BrokenPipeError:
            _stdout_gone()
            return EXIT_FAILURE
        except KeyboardInterrupt:
            if args.debug:
                raise
            print(f"{prog}: interrupted", file=sys.stderr)
            return 130
        except Exception as e:
            if args.debug:
                raise
            if isinstance(e, _input_errors()):
                print(f"{prog}: {_one_line(e)}", file=sys.stderr)
                return EXIT_INPUT
            print(f"{prog}: failed: {type(e).__name__}: {_one_line(e)} (rerun with --debug for the traceback)",
                  file=sys.stderr)
            return EXIT_FAILURE


if __name__ == "__main__":
    sys.exit(main())
