"""`python -m fringe` is the `fringe` command."""

import sys

from .cli.cli import main

sys.exit(main())
