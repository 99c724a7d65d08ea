file(REMOVE_RECURSE
  "CMakeFiles/test_hessian.dir/test_hessian.cpp.o"
  "CMakeFiles/test_hessian.dir/test_hessian.cpp.o.d"
  "test_hessian"
  "test_hessian.pdb"
)

# Per-language clean rules from dependency scanning.
foreach(lang CXX)
  include(CMakeFiles/test_hessian.dir/cmake_clean_${lang}.cmake OPTIONAL)
endforeach()
