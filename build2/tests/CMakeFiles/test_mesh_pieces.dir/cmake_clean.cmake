file(REMOVE_RECURSE
  "CMakeFiles/test_mesh_pieces.dir/test_mesh_pieces.cpp.o"
  "CMakeFiles/test_mesh_pieces.dir/test_mesh_pieces.cpp.o.d"
  "test_mesh_pieces"
  "test_mesh_pieces.pdb"
)

# Per-language clean rules from dependency scanning.
foreach(lang CXX)
  include(CMakeFiles/test_mesh_pieces.dir/cmake_clean_${lang}.cmake OPTIONAL)
endforeach()
