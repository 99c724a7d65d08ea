# Empty compiler generated dependencies file for test_cloth.
# This may be replaced when dependencies are built.
