"""docs/node.md's way of poking the node by hand ("Poking it by hand"; issue
15 #4): its two ``ros2 topic pub --once`` one-liners, sent as ``ros2 topic pub``
sends them (the YAML read from the page, ``stamp: now`` the current time), are each
answered, after an earlier stream too. Checked by hand with the real ``ros2``
CLI; here without it (not on PyPI): the YAML is filled into the message the
way ``ros2 topic pub`` fills it (nested fields, sequences of messages).
"""
from __future__ import annotations

import importlib
import re
import time
from typing import Any

import pytest
import yaml
from rclpy.qos import QoSProfile, ReliabilityPolicy

from node_harness import ROOT, stamp_ns

pytestmark = pytest.mark.ros

def poking_section() -> str:
    """docs/node.md's section "Poking it by hand"."""
    text = (ROOT / 'docs' / 'node.md').read_text()
    return text.split('## Poking it by hand', 1)[1].split('\n## ', 1)[0]


ONE_LINER = re.compile(r'ros2 topic pub --once (/\w+) (\S+) \\\n\s*"(\{.*?\})"\n')


def message_type(name: str) -> type:
    package, _, kind = name.split('/')
    return getattr(importlib.import_module(f'{package}.msg'), kind)


def fill(msg: Any, values: dict, now_ns: int) -> None:
    """``values`` into ``msg`` as ``ros2 topic pub`` does (``stamp: now``)."""
    types = msg.get_fields_and_field_types()
    for key, value in values.items():
        if key == 'stamp' and value == 'now':
            stamp = getattr(msg, key)
            stamp.sec, stamp.nanosec = divmod(now_ns, 1_000_000_000)
        elif isinstance(value, dict):
            fill(getattr(msg, key), value, now_ns)
        elif isinstance(value, list) and value and isinstance(value[0], dict):
            element = message_type(types[key][len('sequence<'):-1].replace('/', '/msg/'))
            items = []
            for item in value:
                items.append(element())
                fill(items[-1], item, now_ns)
            setattr(msg, key, items)
        else:
            setattr(msg, key, [float(v) for v in value] if isinstance(value, list)
                    and types[key].startswith('sequence<double') else value)


def test_readme_one_liners_are_answered(client):
    # the 3-DOF machine's (the hexapod's, after 'On a hexapod': test_node_hexapod.py)
    text = poking_section().split('On a hexapod', 1)[0]
    commands = ONE_LINER.findall(text)
    assert [topic for topic, _, _ in commands] == ['/pose_setpoint', '/platform_setpoint']
    # an earlier stream (its stamps older than now), answered: discovery is done
    earlier = iter(range(time.time_ns() - 5_000_000_000, time.time_ns(), 5_000_000))
    client.round_trip(lambda: next(earlier))
    qos = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE)
    for topic, type_name, body in commands:
        kind = message_type(type_name)
        msg = kind()
        now = time.time_ns()
        fill(msg, yaml.safe_load(body), now)
        pub = client.node.create_publisher(kind, topic, qos)
        assert client.spin_until(lambda: pub.get_subscription_count() > 0, 10.0)
        before = len(client.actuator)
        pub.publish(msg)
        assert client.spin_until(lambda: len(client.actuator) > before, 10.0), \
            f'{topic}: not answered' + client.explain()
        assert stamp_ns(client.actuator[-1][1]) == now
        client.node.destroy_publisher(pub)
