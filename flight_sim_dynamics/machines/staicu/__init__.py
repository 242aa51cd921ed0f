"""The paper's machine: the 3-DOF flight simulator of Staicu, Ocnarescu and Ungureanu (2013)."""
