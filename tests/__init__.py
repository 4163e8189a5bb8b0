"""The test-suite: one folder per openral_data package (tests/<package>/test_<module>.py), helpers in support/."""
