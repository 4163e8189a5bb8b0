"""Tests of openral_data.schemas."""
