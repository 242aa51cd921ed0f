#!/usr/bin/env python3
"""What estimating missing rates/accelerations costs (docs/node.md).

For each motion and rate, the node's estimator (flight_sim_dynamics.setpoints.
DerivativeEstimator, exactly as the node runs it) is fed the stream a planner
would send without accelerations (pose + twist) or with poses only, and the
forces solved from the estimates are compared with the exact ones.
Reported, after the start-up (the first 0.1 s, where the estimator starts
from rest while the paper's motions start with a non-zero acceleration): the
largest and the RMS force error in N, the largest as a percentage of the
largest |force|, and the largest acceleration error; then the largest force
error during the start-up.

    python scripts/measure_estimation.py [--rates 50 100 200] [--markdown]
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

import flight_sim_dynamics as fsd  # noqa: E402
from flight_sim_dynamics.core.cueing import MOTIONS, duration, motion  # noqa: E402
from flight_sim_dynamics.ros.estimator import ESTIMATORS, DerivativeEstimator  # noqa: E402

STARTUP = 0.1  # s


def estimate(method: str, t: np.ndarray, q: np.ndarray, qd: np.ndarray | None
             ) -> tuple[np.ndarray, np.ndarray]:
    est = DerivativeEstimator(method, max_gap=1.0)
    out_qd, out_qdd = [], []
    for k in range(len(t)):
        a, b = est.update(float(t[k]), tuple(q[k]), None if qd is None else tuple(qd[k]), None)
        out_qd.append(a)
        out_qdd.append(b)
    return np.array(out_qd), np.array(out_qdd)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('--rates', type=float, nargs='+', default=[50.0, 100.0, 200.0])
    parser.add_argument('--markdown', action='store_true', help='print a Markdown table')
    args = parser.parse_args()
    model = fsd.load_model()
    rows = []
    for name in MOTIONS:
        for rate in args.rates:
            t = np.arange(0.0, duration(name) + 1e-9, 1.0 / rate)
            q, qd, qdd = motion(name, t)
            exact = fsd.solve_batch(model, q, qd, qdd).force
            scale = np.abs(exact).max()
            for stream in ('pose+twist', 'pose only'):
                for method in ESTIMATORS:
                    qd_e, qdd_e = estimate(method, t, q, qd if stream == 'pose+twist' else None)
                    forces = fsd.solve_batch(model, q, qd_e, qdd_e).force
                    after = t >= STARTUP
                    err = np.abs(forces - exact)
                    rms = float(np.sqrt(np.mean(err[after] ** 2)))
                    acc = np.abs(qdd_e - qdd)[after].max()
                    rows.append((name, rate, stream, method, err[after].max(),
                                 100 * err[after].max() / scale, rms, acc, err[~after].max()))
    if args.markdown:
        print('| motion | rate Hz | stream | estimator | max force error N | % of max force '
              '| RMS N | max accel error | start-up max N |')
        print('|---|---:|---|---|---:|---:|---:|---:|---:|')
        for r in rows:
            print(f'| {r[0]} | {r[1]:g} | {r[2]} | {r[3]} | {r[4]:.2g} | {r[5]:.2g} '
                  f'| {r[6]:.2g} | {r[7]:.2g} | {r[8]:.2g} |')
    else:
        for r in rows:
            print(f'{r[0]:12s} {r[1]:5g} Hz {r[2]:10s} {r[3]:9s} force err max {r[4]:9.3g} N '
                  f'({r[5]:6.2g} %) rms {r[6]:9.3g} N  accel err {r[7]:9.3g}  '
                  f'start-up {r[8]:9.3g} N')
    return 0


if __name__ == '__main__':
    sys.exit(main())
