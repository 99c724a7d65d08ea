file(REMOVE_RECURSE
  "CMakeFiles/test_separation.dir/test_separation.cpp.o"
  "CMakeFiles/test_separation.dir/test_separation.cpp.o.d"
  "test_separation"
  "test_separation.pdb"
)

# Per-language clean rules from dependency scanning.
foreach(lang CXX)
  include(CMakeFiles/test_separation.dir/cmake_clean_${lang}.cmake OPTIONAL)
endforeach()
