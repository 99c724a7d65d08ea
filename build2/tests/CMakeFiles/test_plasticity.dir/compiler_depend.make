# Empty compiler generated dependencies file for test_plasticity.
# This may be replaced when dependencies are built.
