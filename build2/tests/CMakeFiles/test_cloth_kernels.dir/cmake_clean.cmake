file(REMOVE_RECURSE
  "CMakeFiles/test_cloth_kernels.dir/test_cloth_kernels.cpp.o"
  "CMakeFiles/test_cloth_kernels.dir/test_cloth_kernels.cpp.o.d"
  "test_cloth_kernels"
  "test_cloth_kernels.pdb"
)

# Per-language clean rules from dependency scanning.
foreach(lang CXX)
  include(CMakeFiles/test_cloth_kernels.dir/cmake_clean_${lang}.cmake OPTIONAL)
endforeach()
