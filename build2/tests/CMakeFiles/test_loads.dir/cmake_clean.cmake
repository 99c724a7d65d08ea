file(REMOVE_RECURSE
  "CMakeFiles/test_loads.dir/test_loads.cpp.o"
  "CMakeFiles/test_loads.dir/test_loads.cpp.o.d"
  "test_loads"
  "test_loads.pdb"
)

# Per-language clean rules from dependency scanning.
foreach(lang CXX)
  include(CMakeFiles/test_loads.dir/cmake_clean_${lang}.cmake OPTIONAL)
endforeach()
