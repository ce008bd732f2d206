"""Test-suite settings.

In CI (CI=true) hypothesis is derandomised, so a run is repeatable and a
failure can be reproduced from the same commit; locally it explores freely.
No deadline anywhere: a 2-core machine running two workers is no place to time
single examples (speed goals live in bench/).
"""

from __future__ import annotations

import os

from hypothesis import settings

settings.register_profile("ci", derandomize=True, deadline=None, print_blob=True)
settings.register_profile("dev", deadline=None)
settings.load_profile("ci" if os.environ.get("CI") else "dev")
