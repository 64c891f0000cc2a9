"""``python -m imesh ...``: the ``imesh`` command."""

import sys

from .cli import main

sys.exit(main())
