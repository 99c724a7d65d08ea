file(REMOVE_RECURSE
  "CMakeFiles/test_element_state.dir/test_element_state.cpp.o"
  "CMakeFiles/test_element_state.dir/test_element_state.cpp.o.d"
  "test_element_state"
  "test_element_state.pdb"
)

# Per-language clean rules from dependency scanning.
foreach(lang CXX)
  include(CMakeFiles/test_element_state.dir/cmake_clean_${lang}.cmake OPTIONAL)
endforeach()
