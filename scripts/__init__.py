"""Documentation generators of the repository (not installed): run from the
repository root as ``python -m scripts.reproduction_table`` and ``python -m
scripts.node_param_table``. The shell scripts here set up a virtualenv and
run the tests or the demo.
"""
