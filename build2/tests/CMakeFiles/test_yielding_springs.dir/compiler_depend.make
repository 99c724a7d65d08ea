# Empty compiler generated dependencies file for test_yielding_springs.
# This may be replaced when dependencies are built.
