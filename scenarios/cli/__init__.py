"""The ``mrta`` command line: argument parsing (:mod:`~scenarios.cli.parser`), the subcommands
(:mod:`~scenarios.cli.commands`) and the entry point with its one-line errors
(:mod:`~scenarios.cli.app`). ``scenarios.cli:main`` is the console script.
"""

from scenarios.cli.app import main

__all__ = ["main"]
