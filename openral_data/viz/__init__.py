"""Visualisation of episodes with rerun."""
