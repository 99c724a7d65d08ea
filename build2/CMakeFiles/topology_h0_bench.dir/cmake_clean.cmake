file(REMOVE_RECURSE
  "CMakeFiles/topology_h0_bench.dir/bench/topology_h0.cpp.o"
  "CMakeFiles/topology_h0_bench.dir/bench/topology_h0.cpp.o.d"
  "topology_h0_bench"
  "topology_h0_bench.pdb"
)

# Per-language clean rules from dependency scanning.
foreach(lang CXX)
  include(CMakeFiles/topology_h0_bench.dir/cmake_clean_${lang}.cmake OPTIONAL)
endforeach()
