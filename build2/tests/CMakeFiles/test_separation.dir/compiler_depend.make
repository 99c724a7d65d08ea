# Empty compiler generated dependencies file for test_separation.
# This may be replaced when dependencies are built.
