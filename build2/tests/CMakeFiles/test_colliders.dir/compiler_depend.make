# Empty compiler generated dependencies file for test_colliders.
# This may be replaced when dependencies are built.
