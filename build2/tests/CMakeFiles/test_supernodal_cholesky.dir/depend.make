# Empty dependencies file for test_supernodal_cholesky.
# This may be replaced when dependencies are built.
