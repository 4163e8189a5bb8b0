"""Tests of openral_data.cli."""
