file(REMOVE_RECURSE
  "CMakeFiles/test_step_lifecycle.dir/test_step_lifecycle.cpp.o"
  "CMakeFiles/test_step_lifecycle.dir/test_step_lifecycle.cpp.o.d"
  "test_step_lifecycle"
  "test_step_lifecycle.pdb"
)

# Per-language clean rules from dependency scanning.
foreach(lang CXX)
  include(CMakeFiles/test_step_lifecycle.dir/cmake_clean_${lang}.cmake OPTIONAL)
endforeach()
