"""Motion cueing (numpy, no I/O, no rclpy): from a vehicle's specific force and
angular velocity to the platform's setpoints, within what the actuators can do
(design: /work/shared/design/cueing.md).

- :mod:`.params`: the ``cueing`` parameter group (:data:`~.params.PARAMETER_SPECS`,
  :class:`~.params.CueingParams`, :func:`~.params.cueing_params`);
- :mod:`.washout`: the classical washout (:class:`~.washout.Washout`), six channels
  surge, sway, heave, roll, pitch, yaw;
- :mod:`.planner`: the washout and the limiter on a machine, streaming
  (:class:`~.planner.Planner`) and batch (:func:`~.planner.run`);
- :mod:`.limiter`: what keeps every actuator within its limits.
"""
