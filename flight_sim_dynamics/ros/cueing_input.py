"""What the motion-cueing node feeds its planner, output sample by output
sample (no rclpy here): the vehicle's input (specific force and angular
velocity, six numbers) arrives at any rate, irregularly, and the planner
wants one value per output period.

Holding the newest message would step the input at each arrival: the
rotational washout passes the step's derivative to the platform's angular
acceleration (``s · HP_r(s) · k_r`` has a high-frequency gain of ``s``), a
spike of ``k_r · Δω / Δt`` (0.6 · 0.3 rad/s / 1 ms = 180 rad/s² when a
0.3 rad/s yaw rate stops at once). So each new message is reached by a
linear ramp from where the feed is, over the vehicle time between them (the
message's stamp minus the stamp the feed is at, within [one output period,
the input timeout]): on a regular stream this is linear interpolation
between the messages, one message interval late; messages that come late
in a burst are joined over the time they span, not at once. The rest (the
first message, the planner's reference) is reached the same way, over the
input timeout, when the input is stale or the node wants the platform back
at neutral; from the rest, the next message over the timeout too.
"""
from __future__ import annotations

import numpy as np

REST = -1           # the ramp's target: the rest, not a message


class InputFeed:
    """The planner's input, one :meth:`next` per output sample at ``rate``
    (Hz); ``timeout`` (s): the longest ramp, the one to the rest.
    """

    def __init__(self, rate: float, timeout: float) -> None:
        self.rate, self.timeout = float(rate), float(timeout)
        self.rest: np.ndarray | None = None       # the first message: the planner's reference
        self._newest: np.ndarray | None = None
        self._stamp: int | None = None             # ns, of the newest message
        self._seq = 0                              # messages received
        self._target = REST
        self._from = self._to = np.zeros(6)
        # the vehicle times (ns) of the ramp's ends (None: the rest, no time)
        self._from_stamp: int | None = None
        self._to_stamp: int | None = None
        self._j = self._j0 = 0                     # the next sample, the ramp's first
        self._n = 1                                # samples of the ramp

    def receive(self, value: np.ndarray, stamp_ns: int) -> None:
        """A message accepted (six finite numbers, stamps in order)."""
        self._stamp = stamp_ns
        self._newest = np.array(value, dtype=float)
        self._seq += 1

    def next(self, want_rest: bool) -> np.ndarray | None:
        """The value of the next output sample: toward the newest message, or
        toward the rest with ``want_rest``; None before the first message.
        """
        if self.rest is None:
            if self._newest is None:
                return None
            self.rest = self._newest.copy()
            self._from = self._to = self.rest
            self._from_stamp = self._to_stamp = self._stamp
            self._target = self._seq
        target = REST if want_rest else self._seq
        if target != self._target:
            at = self._stamp_at(self._j)
            span = self.timeout if want_rest or at is None else min(
                max((self._stamp - at) * 1e-9, 1.0 / self.rate), self.timeout)
            self._from = self._value(self._j)
            self._to = self.rest if want_rest else self._newest
            self._from_stamp, self._to_stamp = at, None if want_rest else self._stamp
            self._j0 = self._j
            self._n = max(1, round(span * self.rate))
            self._target = target
        value = self._value(self._j)
        self._j += 1
        return value

    def _stamp_at(self, j: int) -> int | None:
        """The vehicle time of sample ``j`` on the ramp (None: on a ramp from or to the rest)."""
        if self._from_stamp is None or self._to_stamp is None:
            return None
        done = min(1.0, (j - self._j0) / self._n)
        return round(self._from_stamp + (self._to_stamp - self._from_stamp) * done)

    def _value(self, j: int) -> np.ndarray:
        done = j - self._j0
        if done >= self._n:
            return self._to
        return self._from + (self._to - self._from) * (done / self._n)


__all__ = ['InputFeed']
