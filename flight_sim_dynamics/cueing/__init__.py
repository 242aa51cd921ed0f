"""Motion cueing (numpy, no I/O, no rclpy): from a vehicle's specific force and
angular velocity to the platform's setpoints, within what the actuators can do
(design: /work/shared/design/cueing.md).

- its parameters, the ``cueing`` group of a params file, are configuration:
  :mod:`flight_sim_dynamics.config.cueing` (``PARAMETER_SPECS``, ``CueingParams``,
  ``cueing_params``);
- :mod:`.washout`: the classical washout (:class:`~.washout.Washout`), six channels
  surge, sway, heave, roll, pitch, yaw;
- :mod:`.planner`: the washout and the limiter on a machine, streaming
  (:class:`~.planner.Planner`) and batch (:func:`~.planner.run`);
- :mod:`.limiter`: what keeps every actuator within its limits.
"""
