"""The tables a closed loop follows (:mod:`.simulation`): the plant's leg
lengths and rates and the feed-forward forces of a reference motion at the
RK4 stage times, from the inverse dynamics (eq. 5-23); a reference sample the
plant cannot follow (unreachable, near a singularity) is a ValueError.

With the compiled kernel, :class:`ClosedLoopPipeline` solves them on the
kernel's worker threads piece by piece ahead of the RK4 loop, and the result
rows of the run behind it. Numpy only.
"""
from __future__ import annotations

import functools

import numpy as np

from . import kernel
from .model import Model
from .solver import Solution, solve_batch
from .status import SEVERITY, Status


def _reference_problem(sol: Solution, times: np.ndarray, what: str) -> None:
    """ValueError at the first reference sample that cannot be tracked."""
    code = np.array([SEVERITY[s] for s in sol.status])
    bad = np.flatnonzero(code >= SEVERITY[Status.NEAR_SINGULAR])
    if bad.size:
        i = int(bad[0])
        raise ValueError(f'{what} at t = {times[i]:.6g} s: {sol.status[i]}: {sol.detail[i]} '
                         f'({bad.size} of {times.size} samples cannot be tracked)')


@functools.cache
def _kernel_severity() -> np.ndarray:
    """SEVERITY of each kernel status code (the kernel is built)."""
    return np.array([SEVERITY[s] for s in kernel.STATUS_BY_CODE])


def reference_tables(model: Model, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray,
                     times: np.ndarray, what: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Leg lengths, rates and forces of ``model`` on the reference samples;
    ValueError at the first one that cannot be tracked. With the kernel its
    result rows are read directly: no Solution and no wording of the samples
    at a limit, which only the error needs (about 1.5 ms of a 30 ms run).
    """
    if kernel.enabled():
        rows = kernel.solve_rows(model, q, qd, qdd)
        if _trackable(rows):
            out = kernel.OUT
            return (rows[:, out['length']].copy(), rows[:, out['rate']].copy(),
                    rows[:, out['force']].copy())
    sol = solve_batch(model, q, qd, qdd)
    _reference_problem(sol, times, what)
    return np.array(sol.length), np.array(sol.rate), np.array(sol.force)


#: Rows per piece of a closed loop through the kernel (:class:`ClosedLoopPipeline`);
#: the first piece is short, as its reference is what the loop waits for.
FIRST_PIECE = 128
PIECE = 512


class ClosedLoopPipeline:
    """A closed loop through the kernel in pieces of rows, on its worker
    threads (:func:`.kernel.pool`): while the RK4 loop integrates a piece,
    the workers solve the reference tables (the plant's leg lengths and rates
    and the feed-forward forces at the stage times) of the pieces ahead and
    the result rows of the pieces behind. Each row is solved alone, so the
    numbers are those of one batch. Measured on 2 cores (the violent motion,
    3 s, median of 21 runs): 27 ms in sequence, 22 ms here.
    """

    def __init__(self, plant: Model, feedforward: Model | None, q: np.ndarray,
                 qd: np.ndarray, qdd: np.ndarray, times: np.ndarray, steps: int) -> None:
        self.plant, self.feedforward, self.motion = plant, feedforward, (q, qd, qdd)
        self.times = times
        self.bounds = [0, *range(min(FIRST_PIECE, steps + 1), steps + 1, PIECE), steps + 1]
        stages = [0, *(2 * b + 1 for b in self.bounds[1:-1]), 2 * steps + 1]
        n = 2 * steps + 1
        self.length_ref, self.rate_ref = np.empty((n, 3)), np.empty((n, 3))
        self.ff = np.zeros((n, 3)) if feedforward is None else np.empty((n, 3))
        self.rows = np.empty((steps + 1, kernel.OUT_SIZE))
        pool = kernel.pool()
        self._tables = [(lo, pool.submit(self._tables_of, lo, hi))
                        for lo, hi in zip(stages[:-1], stages[1:])]
        self._results: list = []
        self._solved = 0            # rows handed to the workers for their results

    def _tables_of(self, lo: int, hi: int) -> bool:
        """The tables of stages lo..hi - 1; False when one cannot be tracked."""
        q, qd, qdd = (a[lo:hi] for a in self.motion)
        cut = np.s_[lo:hi]
        rows = kernel.solve_rows(self.plant, q, qd, qdd, threads=False)
        ok = _trackable(rows)
        out = kernel.OUT
        self.length_ref[cut], self.rate_ref[cut] = rows[:, out['length']], rows[:, out['rate']]
        if self.feedforward is self.plant:
            self.ff[cut] = rows[:, out['force']]
        elif self.feedforward is not None:
            rows = kernel.solve_rows(self.feedforward, q, qd, qdd, threads=False)
            ok = ok and _trackable(rows)
            self.ff[cut] = rows[:, out['force']]
        return ok

    def stops_after(self, k: int) -> list[int]:
        """The ends of the pieces after row k."""
        return [b for b in self.bounds[1:] if b > k]

    def need(self, k: int) -> None:
        """Wait until the tables hold the stages through 2 k (row k's first)."""
        for lo, job in self._tables:
            if lo > 2 * k:
                break
            if not job.result():
                self.check()

    def check(self) -> None:
        """ValueError (:func:`reference_tables`'s) if a reference sample cannot be
        tracked; waits for every piece.
        """
        if not all(job.result() for _, job in self._tables):
            for model, what in ((self.plant, 'the reference motion'),
                                (self.feedforward, 'the feed-forward model')):
                if model is not None:
                    reference_tables(model, *self.motion, self.times, what)

    def finished(self, k: int, rows: tuple) -> None:
        """Rows before k are final: the workers solve the results of whole pieces."""
        q, qd, qdd, _ = rows
        for lo, hi in zip(self.bounds[:-1], self.bounds[1:]):
            if lo >= self._solved and hi <= k:
                self._results.append(kernel.pool().submit(
                    kernel.solve_rows, self.plant, q[lo:hi], qd[lo:hi], qdd[lo:hi],
                    self.rows[lo:hi], False))
                self._solved = hi

    def result_rows(self, q: np.ndarray, qd: np.ndarray, qdd: np.ndarray) -> np.ndarray:
        """The result rows of the run's rows q, qd, qdd (the rest solved here)."""
        n = len(q)
        for job in self._results:
            job.result()
        if self._solved < n:
            kernel.solve_rows(self.plant, q[self._solved:], qd[self._solved:],
                              qdd[self._solved:], self.rows[self._solved:n])
        return self.rows[:n]


def _trackable(rows: np.ndarray) -> bool:
    """No kernel row at or beyond near_singular."""
    severity = _kernel_severity()[rows[:, kernel.O_STATUS].astype(np.intp)]
    return not np.any(severity >= SEVERITY[Status.NEAR_SINGULAR])
