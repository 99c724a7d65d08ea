# Empty dependencies file for test_loads.
# This may be replaced when dependencies are built.
