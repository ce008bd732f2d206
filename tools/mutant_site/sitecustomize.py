"""Loaded at start-up by every Python process a mutation run's test starts (the run puts
this folder on PYTHONPATH): the mutant under test replaces its module there too, so a
test that runs the CLI in a subprocess judges the mutant, not the unmutated source."""

import os
import sys

if os.environ.get("STEPRAMP_MUTANT"):
    sys.path.insert(0, os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    try:
        import mutant_finder

        mutant_finder.install_from_env()
    finally:
        del sys.path[0]
