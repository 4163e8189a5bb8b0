"""Tests of openral_data.convert."""
