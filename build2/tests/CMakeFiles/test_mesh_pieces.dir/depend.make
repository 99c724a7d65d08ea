# Empty dependencies file for test_mesh_pieces.
# This may be replaced when dependencies are built.
