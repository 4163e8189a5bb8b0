"""Tests of openral_data.policies."""
