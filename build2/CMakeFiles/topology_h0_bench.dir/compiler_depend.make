# Empty compiler generated dependencies file for topology_h0_bench.
# This may be replaced when dependencies are built.
