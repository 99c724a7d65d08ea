file(REMOVE_RECURSE
  "CMakeFiles/test_static_step.dir/test_static_step.cpp.o"
  "CMakeFiles/test_static_step.dir/test_static_step.cpp.o.d"
  "test_static_step"
  "test_static_step.pdb"
)

# Per-language clean rules from dependency scanning.
foreach(lang CXX)
  include(CMakeFiles/test_static_step.dir/cmake_clean_${lang}.cmake OPTIONAL)
endforeach()
