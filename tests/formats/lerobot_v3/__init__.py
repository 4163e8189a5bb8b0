"""Tests of openral_data.formats.lerobot_v3."""
