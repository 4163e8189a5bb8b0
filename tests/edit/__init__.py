"""Tests of openral_data.edit."""
