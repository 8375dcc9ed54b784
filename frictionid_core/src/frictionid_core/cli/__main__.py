"""``python -m frictionid_core.cli``: the ``frictionid`` command."""

import sys

from frictionid_core.cli import main

sys.exit(main())
