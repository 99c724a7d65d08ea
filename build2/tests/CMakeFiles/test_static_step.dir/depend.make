# Empty dependencies file for test_static_step.
# This may be replaced when dependencies are built.
