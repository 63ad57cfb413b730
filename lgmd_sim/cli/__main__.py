"""`python -m lgmd_sim.cli`: the same as `lgmd-sim`."""

import sys

from lgmd_sim.cli import main

sys.exit(main())
