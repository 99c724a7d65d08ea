# Empty dependencies file for test_energy_term.
# This may be replaced when dependencies are built.
