"""The composing layer: scenario files, the experiments built from them and the ``mrta`` CLI.

Rooms, each importing only the ones listed after it (and ``learning``, ``allocation``, ``sim``):

- :mod:`scenarios.cli`: the ``mrta`` command line (parser, subcommands, entry point);
- :mod:`scenarios.sweep`: parameter sweeps and studies (many runs, ``runs.csv``, summaries);
- :mod:`scenarios.experiments`: the run protocol, metrics, manifests, figures, ``reproduce``,
  ``compare``, ``soak``;
- :mod:`scenarios.loader`: scenario files (``data/``) read into :class:`sim.scenario.Scenario`
  (whose specs check every value themselves).

Beside them: :mod:`scenarios.envs` (the Gymnasium and PettingZoo entry points),
:mod:`scenarios.protocol` (the public path of the protocol) and :mod:`scenarios.bench`
(``mrta bench``).
"""
