"""``python -m scenarios.cli``: the ``mrta`` command without the console script."""

import sys

from scenarios.cli.app import main

sys.exit(main())
