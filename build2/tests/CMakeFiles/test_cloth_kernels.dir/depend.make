# Empty dependencies file for test_cloth_kernels.
# This may be replaced when dependencies are built.
