"""What estimating missing rates/accelerations costs (docs/node.md), per
planner motion, rate, stream and estimator.

The study itself is the one of ``flight-sim-dynamics bench``
(:func:`flight_sim_dynamics.cli.bench_cases.estimator_cases`: the node's
``DerivativeEstimator`` fed the exact samples, pose + twist or pose only, the
full model solved with its estimates against the exact rates and
accelerations), run here on the planner's motions and rates. After the
start-up (the first ``--startup`` seconds: the estimator starts from rest
while the paper's motions start with a non-zero acceleration) the table gives
the largest and the RMS force error (N, and the largest in % of the motion's
peak |force|) and the largest acceleration error; then the largest force
error during the start-up.

    python -m benchmarks.estimation [--rates 50 100 200] [--startup 0.1] [--markdown]
"""
from __future__ import annotations

import argparse
import math
import sys
from typing import Sequence

import flight_sim_dynamics as fsd
from flight_sim_dynamics.cli.bench_cases import estimator_cases, motion_peaks
from flight_sim_dynamics.core.motions import PLANNER_MOTIONS

HEADER = ('| motion | rate Hz | stream | estimator | max force error N | % of max force '
          '| RMS N | max accel error | start-up max N |')


def rows(rates: Sequence[float], startup_s: float, motions: Sequence[str] = PLANNER_MOTIONS
         ) -> list[tuple]:
    """(motion, rate, stream, estimator, max N, max %, RMS N, max acceleration
    error, start-up max N) for every case.
    """
    model = fsd.load_model()
    out = []
    for rate in rates:
        startup = max(1, math.ceil(startup_s * rate - 1e-9))   # samples with t < startup_s
        peaks = motion_peaks(model, motions, rate)
        for case in estimator_cases(model, peaks, [rate], motions, startup):
            stream = 'pose+twist' if case.source == 'twist' else 'pose only'
            for name in motions:
                e = case.steady[name]
                out.append((name, rate, stream, case.method, e.max, e.max_pct, e.rms,
                            case.accel_max[name], case.startup_max[name]))
    order = {name: i for i, name in enumerate(motions)}
    return sorted(out, key=lambda r: (order[r[0]], r[1]))


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog='python -m benchmarks.estimation',
                                     description=__doc__.split('\n\n')[0])
    parser.add_argument('--rates', type=float, nargs='+', default=[50.0, 100.0, 200.0])
    parser.add_argument('--startup', type=float, default=0.1, metavar='S',
                        help='start-up reported apart, seconds (default 0.1)')
    parser.add_argument('--markdown', action='store_true', help='print a Markdown table')
    args = parser.parse_args(argv)
    if not all(math.isfinite(r) and r >= 10.0 for r in args.rates):
        parser.error('--rates must be finite and at least 10 Hz')
    table = rows(args.rates, args.startup)
    if args.markdown:
        print(HEADER)
        print('|---|---:|---|---|---:|---:|---:|---:|---:|')
        for r in table:
            print(f'| {r[0]} | {r[1]:g} | {r[2]} | {r[3]} | {r[4]:.2g} | {r[5]:.2g} '
                  f'| {r[6]:.2g} | {r[7]:.2g} | {r[8]:.2g} |')
    else:
        for r in table:
            print(f'{r[0]:12s} {r[1]:5g} Hz {r[2]:10s} {r[3]:9s} force err max {r[4]:9.3g} N '
                  f'({r[5]:6.2g} %) rms {r[6]:9.3g} N  accel err {r[7]:9.3g}  '
                  f'start-up {r[8]:9.3g} N')
    return 0


if __name__ == '__main__':
    sys.exit(main())
