"""``python -m solver.workflows doe|bounds|sensitivities ...``: the workflow commands alone."""

import sys

from .commands import main

sys.exit(main())
