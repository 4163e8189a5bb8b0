"""Every LeRobot dataset opens (#30): each command on datasets written by lerobot's own writers, old and new."""
