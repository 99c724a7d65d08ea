# Empty dependencies file for hyperqn_base.
# This may be replaced when dependencies are built.
