"""The ``mrta`` command line: parse, run the subcommand, turn every known failure into one line.

Every bad input (a malformed scenario, an unknown key, a missing file, a negative count) ends
with one line ``mrta: error: <what and where>`` on stderr and exit code 2, never a traceback.
Ctrl-C stops cleanly with exit code 130 and says what was kept.
"""

from __future__ import annotations

import sys

from scenarios.cli.commands import COMMANDS
from scenarios.cli.parser import EXIT_USAGE, build_parser

WHERE = {  # what an interrupted command leaves behind, said on Ctrl-C
    "reproduce": "metrics.json and the figures are written only at the end, so --out is unchanged",
    "compare": "compare.json and the figures are written only at the end, so --out is unchanged",
    "run": "OUT is as it was; with --checkpoint, the checkpoint of the last finished task set "
    "is kept beside it (.OUT.partial/): repeat the command with --resume to continue",
    "sweep": "finished runs are in OUT/runs.csv: repeat the command to run only the missing ones",
    "study": "finished runs are in OUT/<part>/runs.csv: repeat the command to go on",
    "soak": "no output is written by a soak",
}


def main(argv: list[str] | None = None) -> int:
    """Entry point of the ``mrta`` console script."""
    from learning.checkpoint import CheckpointError
    from learning.episode import AllocatorFailure, InvariantError
    from learning.registry import AllocatorError
    from scenarios.experiments.outdir import OutputError, os_error_line
    from scenarios.experiments.protocol import UserError
    from scenarios.loader import ScenarioError
    from sim.maps import MapError
    from sim.tasks import StreamFileError

    args = build_parser().parse_args(argv)
    known = (ScenarioError, StreamFileError, UserError, AllocatorError, OutputError, MapError)
    try:
        return COMMANDS[args.command](args)
    except (*known, CheckpointError, AllocatorFailure) as exc:
        _trace(args, exc)
        print(f"mrta: error: {exc}", file=sys.stderr)
        return EXIT_USAGE
    except FileNotFoundError as exc:
        _trace(args, exc)
        print(f"mrta: error: {exc.filename or exc}: file or folder not found", file=sys.stderr)
        return EXIT_USAGE
    except OSError as exc:  # read-only folder, full disk, a symbolic-link loop ...
        _trace(args, exc)
        print(f"mrta: error: {os_error_line(exc)}", file=sys.stderr)
        return EXIT_USAGE
    except InvariantError as exc:
        print(f"mrta: invariant violated: {exc}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print(
            f"mrta: interrupted; {WHERE.get(args.command, 'completed outputs were kept')}; "
            "nothing was half-written",
            file=sys.stderr,
        )
        return 130


def _trace(args, exc: BaseException) -> None:
    """With ``--debug``, the traceback of ``exc`` (and what caused it) on stderr."""
    if args.debug:
        import traceback

        traceback.print_exception(exc, file=sys.stderr)
