# Empty dependencies file for test_topology_h0.
# This may be replaced when dependencies are built.
