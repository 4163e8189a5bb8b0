"""Tests of openral_data.replay."""
