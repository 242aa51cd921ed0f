"""The 6-UPS Stewart–Gough platform (docs/design/stewart.md): model, inverse
kinematics and dynamics by the recursive per-leg relations (S1)-(S23),
forward kinematics and forward dynamics.

>>> from flight_sim_dynamics.machines.stewart import model, solver
>>> m = model.from_dict(params)                        # the parameter-file layout
>>> sol = solver.solve(m, q, qd, qdd)                  # six numbers each
"""
