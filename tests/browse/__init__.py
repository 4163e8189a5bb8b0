"""Tests of openral_data.browse."""
