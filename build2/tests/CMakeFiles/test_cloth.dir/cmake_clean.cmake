file(REMOVE_RECURSE
  "CMakeFiles/test_cloth.dir/test_cloth.cpp.o"
  "CMakeFiles/test_cloth.dir/test_cloth.cpp.o.d"
  "test_cloth"
  "test_cloth.pdb"
)

# Per-language clean rules from dependency scanning.
foreach(lang CXX)
  include(CMakeFiles/test_cloth.dir/cmake_clean_${lang}.cmake OPTIONAL)
endforeach()
