"""Trust, round 3 (#29): one module per class of hole."""
