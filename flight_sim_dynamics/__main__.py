"""``python -m flight_sim_dynamics``: the command line (see :mod:`.cli`)."""
import sys

from .cli.main import main

if __name__ == '__main__':
    sys.exit(main())
