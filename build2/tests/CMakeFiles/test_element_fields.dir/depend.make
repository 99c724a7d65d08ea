# Empty dependencies file for test_element_fields.
# This may be replaced when dependencies are built.
