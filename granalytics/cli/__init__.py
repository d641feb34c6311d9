"""Command line of granalytics: ``granalytics COMMAND …`` (``granalytics --help`` lists the commands).

One module per command or command group, each adding its commands to the parser and running
them: :mod:`.info`, :mod:`.identify`, :mod:`.stats`, :mod:`.sensitivity`, :mod:`.compare_methods`,
:mod:`.compare_cg`, :mod:`.calibrate`, :mod:`.data` (subset, export-vtk, convert, synthetic,
table), :mod:`.tracking` (track), :mod:`.pbm` (pbm), :mod:`.study` (study) and :mod:`.datasets`
(datasets); the options they share in :mod:`.options`. A command parses its arguments, runs the
analysis and hands the result to the report layer (:mod:`granalytics.report`), which writes it.
Library modules never import this package.

Errors about the input (files, frames, parameters) are printed as one line on stderr with exit
status 2, never as a traceback; warnings as one line each.
"""

from __future__ import annotations

import argparse
import sys

from granalytics._version import __version__
from granalytics.base.errors import GranalyticsError, RunWriteError, exit_after_write_failure, warnings_as_lines
from granalytics.base.interrupts import (interrupted, interrupts_not_lost, raise_dropped_interrupt,
                                         terminate_as_interrupt)
from granalytics.base.threads import prefer_openmp
from granalytics.cli import (calibrate, compare_cg, compare_methods, data, datasets, identify, info, pbm, sensitivity,
                             stats, study, tracking)

__all__ = ["main", "build_parser", "COMMANDS"]

#: the commands in the order of ``granalytics --help``, each with the function that adds its parser
COMMANDS = {
    "info": info.add_info_parser,
    "identify": identify.add_identify_parser,
    "stats": stats.add_stats_parser,
    "sensitivity": sensitivity.add_sensitivity_parser,
    "calibrate": calibrate.add_calibrate_parser,
    "compare-methods": compare_methods.add_compare_methods_parser,
    "compare-cg": compare_cg.add_compare_cg_parser,
    "subset": data.add_subset_parser,
    "track": tracking.add_track_parser,
    "pbm": pbm.add_pbm_parser,
    "study": study.add_study_parser,
    "export-vtk": data.add_export_vtk_parser,
    "convert": data.add_convert_parser,
    "datasets": datasets.add_datasets_parser,
    "synthetic": data.add_synthetic_parser,
    "table": data.add_table_parser,
}
#: commands whose arguments are another program's command line (parsed there, --help included)
_FORWARDED = {"datasets": datasets.forwarded_main}


class _Parser(argparse.ArgumentParser):
    """argparse with its usage errors in one line, ``PROG: error: MESSAGE (see PROG --help)``,
    instead of the usage block before it, and without abbreviated options (``--window`` is not
    ``--window-rev``); its subcommands' parsers are of this class too."""

    def __init__(self, *args, **kwargs):
        kwargs.setdefault("allow_abbrev", False)
        super().__init__(*args, **kwargs)

    def error(self, message):
        import difflib
        import re

        invalid = re.match(r"argument (\S+): invalid choice: '([^']*)' \(choose from (.*)\)$", message)
        if invalid:  # a mistyped command or choice: the closest one it has
            choices = re.findall(r"'([^']*)'", invalid[3])
            close = difflib.get_close_matches(invalid[2], choices, n=1, cutoff=0.6)
            if close:
                message += f"; did you mean {close[0]!r}?"
        self.exit(2, f"{self.prog}: error: {message} (see {self.prog} --help)\n")


def _unrecognized(parser, args, extras) -> str:
    """The one-line error for options the command does not have, with the closest it has."""
    import difflib

    command = parser._subparsers._group_actions[0].choices.get(getattr(args, "command", None))
    known = list(command._option_string_actions) if command is not None else []
    hints = []
    for token in extras:
        name = token.split("=", 1)[0]
        close = difflib.get_close_matches(name, known, n=1, cutoff=0.6) if name.startswith("-") else []
        if close:
            hints.append(f"{name}: did you mean {close[0]}?")
    prog = command.prog if command is not None else parser.prog
    return (f"{prog}: error: unrecognized arguments: {' '.join(extras)}" + (f" ({'; '.join(hints)})" if hints else "")
            + f" (see {prog} --help)")


def build_parser() -> argparse.ArgumentParser:
    """The ``granalytics`` argument parser with every command of :data:`COMMANDS`."""
    parser = _Parser(prog="granalytics", description="Granule analytics for wet-granulation DEM runs.")
    parser.add_argument("--version", action="version", version=f"granalytics {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for add in COMMANDS.values():
        add(sub)
    return parser


#: the exit status of the last command that ran to its end (None while one runs, or before):
#: :mod:`granalytics.__main__` tells by it a Ctrl-C after the command finished from one before it started
finished = None


def main(argv=None):
    """Entry point of the ``granalytics`` console script; returns the exit status."""
    global finished

    finished = None
    argv = sys.argv[1:] if argv is None else list(argv)
    # a Ctrl-C that lands in a __del__ or GC callback is raised later, not dropped; SIGTERM cleans up as Ctrl-C
    with interrupts_not_lost(), terminate_as_interrupt():
        return _main(argv)


def _done(status):
    """``status``, recorded as :data:`finished`: the command has run to its end."""
    global finished

    finished = status
    return status


def _main(argv):
    if argv[:1] and argv[0] in _FORWARDED:  # another command line, options and --help included
        return _done(_FORWARDED[argv[0]](argv[1:]))
    parser = build_parser()
    args, extras = parser.parse_known_args(argv)
    if extras:
        print(_unrecognized(parser, args, extras), file=sys.stderr)
        return _done(2)
    import matplotlib

    matplotlib.use("Agg")  # the command line only writes figures to files
    prefer_openmp()  # the command line tunes its own process; the library never does
    with warnings_as_lines("granalytics"):
        try:
            status = args.func(args)
        except (KeyboardInterrupt, SystemError) as exc:
            if not interrupted(exc):
                raise
            print(f"granalytics: {args.command}: interrupted; no output was replaced (outputs are written whole "
                  "or not at all)", file=sys.stderr)
            return _done(130)
        except BrokenPipeError:  # the reader went away (granalytics info RUN | head): quietly, as Unix tools do
            _silence_stdout()
            return _done(141)
        except (GranalyticsError, OSError, ValueError, OverflowError) as exc:  # bad input or environment: one line
            print(f"granalytics: error: {exc}", file=sys.stderr)
            if isinstance(exc, RunWriteError):  # HDF5 cannot close the broken file: no interpreter shutdown
                exit_after_write_failure(2)
            return _done(2)
        try:  # a Ctrl-C that Python dropped after the command's last output was written
            raise_dropped_interrupt()
        except KeyboardInterrupt:
            print(f"granalytics: {args.command}: interrupted as it finished; the outputs it wrote are whole",
                  file=sys.stderr)
            return _done(130)
        return _done(status)


def _silence_stdout():
    """Point stdout at /dev/null, so that flushing it at exit raises no second BrokenPipeError."""
    import os

    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError):  # no real file descriptor (e.g. captured by a test)
        pass
