# Empty dependencies file for test_contact.
# This may be replaced when dependencies are built.
