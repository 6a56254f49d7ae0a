"""Parameter sweeps and studies: many runs of the protocol from one TOML file, resumable.

- :mod:`~scenarios.sweep.spec`: sweep files, validated and expanded into run specs;
- :mod:`~scenarios.sweep.columns`: the metric columns of ``runs.csv``;
- :mod:`~scenarios.sweep.runner`: runs them locally or on Dask, one ``runs.csv`` row at a time;
- :mod:`~scenarios.sweep.report`: rows read back, summaries and sensitivity plots;
- :mod:`~scenarios.sweep.study` (with ``study_analysis`` and ``study_figures``): several
  bundled sweeps run into one folder and read together (``mrta study refusal``).

Sweeps sit on the experiments (:mod:`scenarios.experiments`) and know nothing of the command
line (:mod:`scenarios.cli`).
"""

from scenarios.sweep.runner import run_sweep
from scenarios.sweep.spec import SweepSpec, bundled_sweeps, load_sweep

__all__ = ["SweepSpec", "bundled_sweeps", "load_sweep", "run_sweep"]
