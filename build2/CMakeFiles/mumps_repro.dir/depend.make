# Empty dependencies file for mumps_repro.
# This may be replaced when dependencies are built.
