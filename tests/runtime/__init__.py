"""Tests of openral_data.record."""
