"""Tests of openral_data.doctor."""
