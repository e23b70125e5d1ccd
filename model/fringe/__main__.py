"""`python -m fringe` is the `fringe` command."""

import sys

from .cli import main

sys.exit(main())
