file(REMOVE_RECURSE
  "CMakeFiles/test_element_fields.dir/test_element_fields.cpp.o"
  "CMakeFiles/test_element_fields.dir/test_element_fields.cpp.o.d"
  "test_element_fields"
  "test_element_fields.pdb"
)

# Per-language clean rules from dependency scanning.
foreach(lang CXX)
  include(CMakeFiles/test_element_fields.dir/cmake_clean_${lang}.cmake OPTIONAL)
endforeach()
