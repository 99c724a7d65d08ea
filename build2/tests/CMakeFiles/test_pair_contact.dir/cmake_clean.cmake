file(REMOVE_RECURSE
  "CMakeFiles/test_pair_contact.dir/test_pair_contact.cpp.o"
  "CMakeFiles/test_pair_contact.dir/test_pair_contact.cpp.o.d"
  "test_pair_contact"
  "test_pair_contact.pdb"
)

# Per-language clean rules from dependency scanning.
foreach(lang CXX)
  include(CMakeFiles/test_pair_contact.dir/cmake_clean_${lang}.cmake OPTIONAL)
endforeach()
