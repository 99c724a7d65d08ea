file(REMOVE_RECURSE
  "CMakeFiles/test_viscoelastic.dir/test_viscoelastic.cpp.o"
  "CMakeFiles/test_viscoelastic.dir/test_viscoelastic.cpp.o.d"
  "test_viscoelastic"
  "test_viscoelastic.pdb"
)

# Per-language clean rules from dependency scanning.
foreach(lang CXX)
  include(CMakeFiles/test_viscoelastic.dir/cmake_clean_${lang}.cmake OPTIONAL)
endforeach()
