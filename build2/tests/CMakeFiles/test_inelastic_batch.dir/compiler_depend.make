# Empty compiler generated dependencies file for test_inelastic_batch.
# This may be replaced when dependencies are built.
