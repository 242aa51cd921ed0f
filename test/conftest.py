"""Shared pytest configuration."""
from __future__ import annotations

import os
import random

import pytest


# ---------------------------------------------------------------------------
# ROS 2 isolation (node tests): every test run gets its own ROS domain and
# discovery limited to this machine, unless the caller already chose them
# (scripts/run_tests.sh does). Child processes (the node) inherit them.
# ---------------------------------------------------------------------------
@pytest.fixture(scope='session', autouse=True)
def ros_isolation() -> None:
    if not os.environ.get('ROS_DOMAIN_ID'):
        os.environ['ROS_DOMAIN_ID'] = str(random.randint(1, 100))
    os.environ.setdefault('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST')
    yield


# ---------------------------------------------------------------------------
# Hypothesis profiles (property-based tests: test_workspace_properties.py,
# test_hard_cases.py, test_csv_garbage.py and any test without its own
# max_examples):
#
#   ci    (default) 100 examples per property test. The workspace tests draw
#         a batch of 24..32 samples per example, so each of them checks about
#         2,500 (pose, rate, acceleration) cases per run, and the three
#         hard-cases files together run in ~40 s on a 2-core machine.
#   long  20x as many examples (2000 per test, ~50,000 cases per workspace
#         property; ~8 min for the three files): a soak run before a release,
#         or after touching the solver, e.g.
#             FSD_HYPOTHESIS_PROFILE=long PYTHONPATH=. python -m pytest -q \
#                 test/core/test_workspace_properties.py test/core/test_hard_cases.py \
#                 test/cli/test_csv_garbage.py
#
# Select one with the environment variable FSD_HYPOTHESIS_PROFILE (ci or
# long; any other name is an error). Both have no deadline: a solve near a
# singularity or a forward-kinematics iteration may legitimately take longer
# than Hypothesis' default 200 ms on a loaded CI machine. Tests that set their
# own max_examples keep it; the hard-cases tests scale theirs from the profile
# (hypothesis.settings.default.max_examples), so `long` makes them 20x longer.
# ---------------------------------------------------------------------------
from hypothesis import settings as _hypothesis_settings  # noqa: E402

HYPOTHESIS_PROFILES = {'ci': 100, 'long': 2000}
for _name, _examples in HYPOTHESIS_PROFILES.items():
    _hypothesis_settings.register_profile(_name, max_examples=_examples, deadline=None,
                                          print_blob=True)
_profile = os.environ.get('FSD_HYPOTHESIS_PROFILE', 'ci')
if _profile not in HYPOTHESIS_PROFILES:
    raise ValueError(f'FSD_HYPOTHESIS_PROFILE={_profile!r}: expected one of '
                     f'{", ".join(HYPOTHESIS_PROFILES)}')
_hypothesis_settings.load_profile(_profile)


# ---------------------------------------------------------------------------
# Solver implementation under test: the compiled kernel (default, when built;
# scripts/run_tests.sh builds it and sets FSD_REQUIRE_KERNEL=1 so that a
# failed build fails the run) or, with FSD_KERNEL=0, the Python reference code
# for the whole suite:  FSD_KERNEL=0 PYTHONPATH=. python -m pytest -q test
# test/core/test_kernel.py checks the two against each other in every run.
# ---------------------------------------------------------------------------
# (read by flight_sim_dynamics.kernel itself, so the node and command-line
# processes the tests start follow the same choice)
