"""Tests of openral_data.metrics."""
