# Empty compiler generated dependencies file for test_partition_file.
# This may be replaced when dependencies are built.
