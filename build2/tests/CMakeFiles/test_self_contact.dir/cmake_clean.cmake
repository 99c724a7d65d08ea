file(REMOVE_RECURSE
  "CMakeFiles/test_self_contact.dir/test_self_contact.cpp.o"
  "CMakeFiles/test_self_contact.dir/test_self_contact.cpp.o.d"
  "test_self_contact"
  "test_self_contact.pdb"
)

# Per-language clean rules from dependency scanning.
foreach(lang CXX)
  include(CMakeFiles/test_self_contact.dir/cmake_clean_${lang}.cmake OPTIONAL)
endforeach()
