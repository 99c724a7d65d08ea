# Empty dependencies file for cholmod_updown.
# This may be replaced when dependencies are built.
