file(REMOVE_RECURSE
  "CMakeFiles/test_yielding_springs.dir/test_yielding_springs.cpp.o"
  "CMakeFiles/test_yielding_springs.dir/test_yielding_springs.cpp.o.d"
  "test_yielding_springs"
  "test_yielding_springs.pdb"
)

# Per-language clean rules from dependency scanning.
foreach(lang CXX)
  include(CMakeFiles/test_yielding_springs.dir/cmake_clean_${lang}.cmake OPTIONAL)
endforeach()
