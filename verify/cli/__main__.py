"""`python -m verify.cli …` runs the `stepramp` command."""

import sys

from verify.cli import main

sys.exit(main())
