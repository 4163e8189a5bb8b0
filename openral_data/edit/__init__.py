"""Episode editing: delete, split and merge LeRobot v3 datasets (see ops.py)."""
