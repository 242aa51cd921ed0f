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
