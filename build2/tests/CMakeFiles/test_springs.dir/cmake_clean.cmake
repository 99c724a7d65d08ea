file(REMOVE_RECURSE
  "CMakeFiles/test_springs.dir/test_springs.cpp.o"
  "CMakeFiles/test_springs.dir/test_springs.cpp.o.d"
  "test_springs"
  "test_springs.pdb"
)

# Per-language clean rules from dependency scanning.
foreach(lang CXX)
  include(CMakeFiles/test_springs.dir/cmake_clean_${lang}.cmake OPTIONAL)
endforeach()
