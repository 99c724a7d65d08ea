file(REMOVE_RECURSE
  "CMakeFiles/test_base64.dir/test_base64.cpp.o"
  "CMakeFiles/test_base64.dir/test_base64.cpp.o.d"
  "test_base64"
  "test_base64.pdb"
)

# Per-language clean rules from dependency scanning.
foreach(lang CXX)
  include(CMakeFiles/test_base64.dir/cmake_clean_${lang}.cmake OPTIONAL)
endforeach()
