"""How long one parameter request holds the node's only thread (issue 12 #4).

Every callback of the node runs on one thread, so the time the parameter
service spends on a request is the time setpoints wait. This measures that
time in-process, by calling the node's SetParameters / SetParametersAtomically
handlers directly (no DDS in the figure), for the requests that matter: one
parameter, the largest accepted request (256 parameters), the same with one
bad value (the service then finds the bad one), every parameter of the node,
a conflict between parameters that are each in range (the service halves
the request to find which fail), the worst case (every value conflicts: the
validation budget is spent), and an oversized request (refused whole).

    python -m benchmarks.param_requests [--repeat N]

Prints a table (best and worst of N runs, ms). Not a test: figures only.
"""
from __future__ import annotations

import argparse
import logging
import time
from typing import Any, Sequence

import rclpy
from rcl_interfaces.srv import SetParameters, SetParametersAtomically
from rclpy.parameter import Parameter

from flight_sim_dynamics.config import parameters as prm
from flight_sim_dynamics.ros.dynamics_node import DynamicsNode
from flight_sim_dynamics.ros.node_parameters import NodeParameters
from flight_sim_dynamics.ros.parameter_service import (MAX_PARAMETERS_PER_REQUEST,
                                                       ParameterServices)


def cases(node: DynamicsNode) -> list[tuple[str, str, list[Parameter]]]:
    ours = [node.get_parameter(name) for name in prm.SPECS]
    gravity = Parameter('gravity', value=9.81)
    bad = Parameter('gravity', value=-1.0e9)
    n = MAX_PARAMETERS_PER_REQUEST
    return [
        ('set', '1 model parameter (gravity)', [gravity]),
        ('set', '1 node parameter (sync.wait)', [Parameter('sync.wait', value=0.05)]),
        ('set', f'{n} x gravity (largest accepted request)', [gravity] * n),
        ('atomic', f'{n} x gravity, atomically', [gravity] * n),
        ('set', f'{n - 1} x gravity + 1 out of range', [gravity] * (n - 1) + [bad]),
        ('set', f'{n} distinct gravity values, the last out of range',
         [Parameter('gravity', value=9.0 + k * 1e-3) for k in range(n - 1)] + [bad]),
        ('set', f'{n - 1} distinct stroke_min + 1 above stroke_max (halving)',
         [Parameter('limits.stroke_min', value=-0.3 + k * 1e-4) for k in range(n - 1)]
         + [Parameter('limits.stroke_min', value=0.7)]),
        ('set', f'{n} distinct stroke_min, all above stroke_max (budget spent)',
         [Parameter('limits.stroke_min', value=0.7 + k * 1e-4) for k in range(n)]),
        ('set', f'every parameter of the node ({len(ours)})', ours),
        ('set', f'every parameter + 1 out of range ({len(ours) + 1})', ours + [bad]),
        ('set', f'{n + 1} x gravity (refused whole)', [gravity] * (n + 1)),
    ]


def measure(services: ParameterServices, kind: str, params: Sequence[Parameter],
            repeat: int) -> tuple[float, float, int]:
    times = []
    ok = 0
    msgs = [p.to_parameter_msg() for p in params]
    for _ in range(repeat):
        if kind == 'set':
            request, response = SetParameters.Request(parameters=msgs), SetParameters.Response()
            t0 = time.perf_counter()
            results: Any = services._set(request, response).results
        else:
            request = SetParametersAtomically.Request(parameters=msgs)
            t0 = time.perf_counter()
            results = [services._set_atomically(request,
                                                SetParametersAtomically.Response()).result]
        times.append(time.perf_counter() - t0)
        ok = sum(r.successful for r in results)
    return min(times), max(times), ok


def main(argv: Sequence[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog='python -m benchmarks.param_requests',
                                description=__doc__.split('\n\n')[0])
    p.add_argument('--repeat', type=int, default=5)
    args = p.parse_args(argv)
    rclpy.init()
    try:
        node = DynamicsNode()
        node.get_logger().set_level(logging.WARNING)
        assert node.start(), node.failure       # configure + activate, as autostart does
        services = ParameterServices(node, NodeParameters.precheck)
        print(f'{"request":58s} {"best ms":>9s} {"worst ms":>9s}  accepted')
        for kind, label, params in cases(node):
            best, worst, ok = measure(services, kind, params, args.repeat)
            total = len(params) if kind == 'set' else 1
            print(f'{label:58s} {best * 1e3:9.2f} {worst * 1e3:9.2f}  {ok}/{total}')
        node.destroy_node()
    finally:
        rclpy.try_shutdown()
    return 0


if __name__ == '__main__':
    raise SystemExit(main())
