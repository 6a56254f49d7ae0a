"""``scenarios.protocol``, the public path of the experiment protocol.

The protocol lives in :mod:`scenarios.experiments.protocol` (and its file writers in
:mod:`scenarios.experiments.output`); scripts and notebooks keep importing ``RunSpec``,
``build_run``, ``execute`` and ``run_many`` from here.
"""

from scenarios.experiments.output import write_csv_atomic, write_json_atomic
from scenarios.experiments.protocol import (
    RunSpec,
    UserError,
    apply_overrides,
    build_run,
    check_cost,
    check_stream,
    default_workers,
    execute,
    load_named,
    run_many,
)

__all__ = [
    "RunSpec",
    "UserError",
    "apply_overrides",
    "build_run",
    "check_cost",
    "check_stream",
    "default_workers",
    "execute",
    "load_named",
    "run_many",
    "write_csv_atomic",
    "write_json_atomic",
]
