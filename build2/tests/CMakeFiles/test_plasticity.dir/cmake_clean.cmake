file(REMOVE_RECURSE
  "CMakeFiles/test_plasticity.dir/test_plasticity.cpp.o"
  "CMakeFiles/test_plasticity.dir/test_plasticity.cpp.o.d"
  "test_plasticity"
  "test_plasticity.pdb"
)

# Per-language clean rules from dependency scanning.
foreach(lang CXX)
  include(CMakeFiles/test_plasticity.dir/cmake_clean_${lang}.cmake OPTIONAL)
endforeach()
