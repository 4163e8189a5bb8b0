"""Tests of openral_data.pipeline."""
