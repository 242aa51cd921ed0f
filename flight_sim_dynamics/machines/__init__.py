"""The machines' physics, one subpackage per machine (numpy, no I/O).

Each subpackage holds what belongs to one machine: its parameters (model),
kinematics and dynamics; what machines share (statuses, effects and scenes)
lives in :mod:`flight_sim_dynamics.core`.
"""
