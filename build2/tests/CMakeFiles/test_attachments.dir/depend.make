# Empty dependencies file for test_attachments.
# This may be replaced when dependencies are built.
