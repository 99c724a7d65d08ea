file(REMOVE_RECURSE
  "CMakeFiles/test_deck.dir/test_deck.cpp.o"
  "CMakeFiles/test_deck.dir/test_deck.cpp.o.d"
  "test_deck"
  "test_deck.pdb"
)

# Per-language clean rules from dependency scanning.
foreach(lang CXX)
  include(CMakeFiles/test_deck.dir/cmake_clean_${lang}.cmake OPTIONAL)
endforeach()
