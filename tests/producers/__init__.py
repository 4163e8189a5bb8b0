"""Tests of openral_data.producers."""
