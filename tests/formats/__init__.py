"""Tests of openral_data.formats."""
