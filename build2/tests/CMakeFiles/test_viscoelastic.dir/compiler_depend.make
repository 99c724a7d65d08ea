# Empty compiler generated dependencies file for test_viscoelastic.
# This may be replaced when dependencies are built.
