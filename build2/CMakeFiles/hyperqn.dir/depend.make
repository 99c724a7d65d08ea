# Empty dependencies file for hyperqn.
# This may be replaced when dependencies are built.
