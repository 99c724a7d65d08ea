# Empty compiler generated dependencies file for test_step_lifecycle.
# This may be replaced when dependencies are built.
