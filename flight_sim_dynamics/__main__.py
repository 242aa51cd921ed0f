"""``python -m flight_sim_dynamics`` and the console script ``flight-sim-dynamics``:
the command line (see :mod:`.cli`).
"""
import sys

try:
    from .cli.main import main
except KeyboardInterrupt:       # Ctrl-C while numpy loads: as quiet as later (cli.main.main)
    print('error: interrupted', file=sys.stderr)
    sys.exit(130)

if __name__ == '__main__':
    sys.exit(main())
