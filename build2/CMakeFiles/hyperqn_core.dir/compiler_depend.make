# Empty compiler generated dependencies file for hyperqn_core.
# This may be replaced when dependencies are built.
