file(REMOVE_RECURSE
  "CMakeFiles/test_supernodal_cholesky.dir/test_supernodal_cholesky.cpp.o"
  "CMakeFiles/test_supernodal_cholesky.dir/test_supernodal_cholesky.cpp.o.d"
  "test_supernodal_cholesky"
  "test_supernodal_cholesky.pdb"
)

# Per-language clean rules from dependency scanning.
foreach(lang CXX)
  include(CMakeFiles/test_supernodal_cholesky.dir/cmake_clean_${lang}.cmake OPTIONAL)
endforeach()
