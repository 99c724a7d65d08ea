# Empty compiler generated dependencies file for test_hessian.
# This may be replaced when dependencies are built.
