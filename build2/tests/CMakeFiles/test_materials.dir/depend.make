# Empty dependencies file for test_materials.
# This may be replaced when dependencies are built.
