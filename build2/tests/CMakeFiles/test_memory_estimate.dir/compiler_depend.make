# Empty compiler generated dependencies file for test_memory_estimate.
# This may be replaced when dependencies are built.
