"""The motion-cueing node's input feed (ros/cueing_input.py, no ROS): linear
interpolation of a regular stream one message late, never a step whatever
the arrivals, the rest reached over the timeout.
"""
from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from flight_sim_dynamics.ros.cueing_input import InputFeed

RATE = 1000.0           # Hz, output samples
MS = 1_000_000          # ns


def test_nothing_before_the_first_message_then_it_is_the_rest():
    feed = InputFeed(RATE, 0.2)
    assert feed.next(False) is None and feed.next(True) is None
    first = np.arange(6.0)
    feed.receive(first, 0)
    assert np.array_equal(feed.next(False), first)
    assert np.array_equal(feed.rest, first)


def test_a_regular_stream_is_interpolated_linearly_one_message_late():
    feed = InputFeed(RATE, 0.2)
    rng = np.random.default_rng(3)
    values = rng.uniform(-5.0, 5.0, (20, 6))
    out = []
    for i, value in enumerate(values):          # 100 Hz: one message before every 10th sample
        feed.receive(value, i * 10 * MS)
        out += [feed.next(False) for _ in range(10)]
    out = np.array(out)
    j = np.arange(10, len(out))
    # message i is reached at sample 10 (i + 1), on the line from message i - 1
    times = 10.0 * (np.arange(len(values)) + 1)
    expected = np.stack([np.interp(j, times, values[:, c]) for c in range(6)], axis=1)
    np.testing.assert_allclose(out[10:], expected, rtol=0, atol=1e-12)


def test_the_rest_is_reached_over_the_timeout_and_the_stream_rejoined():
    feed = InputFeed(RATE, 0.2)
    rest, moving = np.zeros(6), np.full(6, 3.0)
    feed.receive(rest, 0)
    feed.next(False)
    feed.receive(moving, 10 * MS)
    for _ in range(10):
        feed.next(False)
    assert np.array_equal(feed.next(False), moving)
    to_rest = np.array([feed.next(True) for _ in range(201)])
    assert np.all(np.diff(to_rest[:, 0]) < 0) and np.array_equal(to_rest[200], rest)
    np.testing.assert_allclose(np.diff(to_rest[:200, 0]), -3.0 / 200, rtol=1e-12)
    # the stream again, after a gap of seconds: joined over the timeout, not at once
    feed.receive(moving, 5000 * MS)
    back = np.array([feed.next(False) for _ in range(201)])
    assert np.max(np.abs(np.diff(back[:, 0]))) <= 3.0 / 200 + 1e-12
    assert np.array_equal(back[200], moving)


def test_a_late_burst_is_joined_over_the_time_it_spans():
    """20 messages 10 ms apart, taken at once (a node that was held up): the
    feed goes to the last over the 200 ms they span, not over the last's 10 ms."""
    feed = InputFeed(RATE, 0.5)
    feed.receive(np.zeros(6), 0)
    feed.next(False)
    for i in range(1, 21):
        feed.receive(np.full(6, i / 20), i * 10 * MS)
    out = np.array([feed.next(False) for _ in range(201)])
    np.testing.assert_allclose(np.diff(out[:, 0])[:200], 1.0 / 200, rtol=1e-9)
    assert out[200, 0] == 1.0


@settings(max_examples=100, deadline=None)
@given(st.lists(st.tuples(st.integers(0, 40),                      # samples before it
                          st.integers(10, 300),                    # ms since the last
                          st.lists(st.floats(-10.0, 10.0), min_size=6, max_size=6),
                          st.booleans()),                          # the node wants the rest
                min_size=2, max_size=40))
def test_whatever_the_arrivals_the_feed_never_steps(messages):
    """Messages in bursts (0 samples between them) or late, values anywhere in
    [-10, 10], the rest wanted now and then: from one sample to the next the
    feed moves at most the whole range over the shortest ramp (10 ms: 10
    samples); holding the newest message would step by up to the whole range."""
    feed = InputFeed(RATE, 0.2)
    stamp, out, want_rest = 0, [], False
    for before, gap, value, rest in messages:
        for _ in range(before):
            fed = feed.next(want_rest)
            if fed is not None:
                out.append(fed)
        stamp += gap * MS
        feed.receive(np.array(value), stamp)
        want_rest = rest
    out += [feed.next(want_rest) for _ in range(250)]
    steps = np.abs(np.diff(np.array(out), axis=0))
    assert steps.max(initial=0.0) <= 20.0 / 10 + 1e-9
