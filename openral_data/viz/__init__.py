"""Visualisation of episodes with rerun."""

DEFAULT_PORT = 9876  # rerun's own default: the port of a spawned viewer or a served stream (`--view-port`)
