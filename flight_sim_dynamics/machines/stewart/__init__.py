"""The 6-UPS Stewart–Gough platform (docs/design/stewart.md): model, inverse
kinematics and dynamics by the recursive per-leg relations (S1)-(S23),
forward kinematics and forward dynamics.

Use::

    from flight_sim_dynamics.machines.stewart import model, solver
    m = model.from_dict(params)              # a file's ros__parameters (stewart.md)
    sol = solver.solve(m, q, qd, qdd)        # six numbers each; solve_batch: (N, 6)

The solver runs the compiled kernel (``kernel.c``, built as ``_kernel``) when it
is built, else the numpy code, the reference it is tested against.
"""
