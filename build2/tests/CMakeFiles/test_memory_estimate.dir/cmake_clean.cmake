file(REMOVE_RECURSE
  "CMakeFiles/test_memory_estimate.dir/test_memory_estimate.cpp.o"
  "CMakeFiles/test_memory_estimate.dir/test_memory_estimate.cpp.o.d"
  "test_memory_estimate"
  "test_memory_estimate.pdb"
)

# Per-language clean rules from dependency scanning.
foreach(lang CXX)
  include(CMakeFiles/test_memory_estimate.dir/cmake_clean_${lang}.cmake OPTIONAL)
endforeach()
