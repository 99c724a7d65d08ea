file(REMOVE_RECURSE
  "CMakeFiles/test_topology_h0.dir/test_topology_h0.cpp.o"
  "CMakeFiles/test_topology_h0.dir/test_topology_h0.cpp.o.d"
  "test_topology_h0"
  "test_topology_h0.pdb"
)

# Per-language clean rules from dependency scanning.
foreach(lang CXX)
  include(CMakeFiles/test_topology_h0.dir/cmake_clean_${lang}.cmake OPTIONAL)
endforeach()
