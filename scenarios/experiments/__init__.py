"""The experiments: one run from a spec (:mod:`~scenarios.experiments.protocol`), its metrics,
manifest and output files, the figures, and the commands built from runs: ``reproduce``,
``compare`` and ``soak``. Builds on the scenario files (:mod:`scenarios.loader`) and on
``learning``, ``allocation`` and ``sim``; knows nothing of sweeps or the command line.
"""
