"""QoS of the node's setpoints and outputs: the default profile, and what a
start-up ``qos_overrides.*`` parameter (rclpy's QoSOverridingOptions) may
change.
"""
from __future__ import annotations

from rcl_interfaces.msg import SetParametersResult
from rclpy.qos import (DurabilityPolicy, HistoryPolicy, QoSPolicyKind, QoSProfile,
                       ReliabilityPolicy)


def default_qos() -> QoSProfile:
    """QoS of setpoints and outputs before overrides: reliable, KEEP_LAST 1000
    (1 s at 1 kHz: absorbs a stall of the node or the planner), VOLATILE (a
    late joiner must not get stale setpoints or forces; not overridable). A
    new profile per endpoint: rclpy writes the overrides into it.
    """
    return QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1000,
                      reliability=ReliabilityPolicy.RELIABLE,
                      durability=DurabilityPolicy.VOLATILE)


def describe_qos(qos: QoSProfile) -> str:
    """``reliable keep_last 1000`` (for the start-up log)."""
    return f'{qos.reliability.name.lower()} {qos.history.name.lower()} {qos.depth}'


#: The policies a start-up ``qos_overrides.*`` parameter may set.
QOS_POLICIES = (QoSPolicyKind.HISTORY, QoSPolicyKind.DEPTH, QoSPolicyKind.RELIABILITY)


def check_qos(qos: QoSProfile) -> SetParametersResult:
    """Reject overrides that cannot work: KEEP_LAST with depth < 1, or a
    reliability other than reliable / best_effort (system_default would make
    the node's behaviour depend on the middleware's configuration).
    """
    if qos.history == HistoryPolicy.KEEP_LAST and qos.depth < 1:
        return SetParametersResult(successful=False,
                                   reason=f'depth must be >= 1 with keep_last, got {qos.depth}')
    if qos.reliability not in (ReliabilityPolicy.RELIABLE, ReliabilityPolicy.BEST_EFFORT):
        return SetParametersResult(successful=False, reason='reliability must be reliable or '
                                   f'best_effort, got {qos.reliability.name.lower()}')
    return SetParametersResult(successful=True)
