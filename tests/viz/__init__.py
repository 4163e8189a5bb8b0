"""Tests of openral_data.viz."""
