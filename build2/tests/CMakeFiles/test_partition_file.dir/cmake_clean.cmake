file(REMOVE_RECURSE
  "CMakeFiles/test_partition_file.dir/test_partition_file.cpp.o"
  "CMakeFiles/test_partition_file.dir/test_partition_file.cpp.o.d"
  "test_partition_file"
  "test_partition_file.pdb"
)

# Per-language clean rules from dependency scanning.
foreach(lang CXX)
  include(CMakeFiles/test_partition_file.dir/cmake_clean_${lang}.cmake OPTIONAL)
endforeach()
