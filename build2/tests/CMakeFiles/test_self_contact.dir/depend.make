# Empty dependencies file for test_self_contact.
# This may be replaced when dependencies are built.
