"""`record --workers N [--executor local|ray]`: episodes recorded in N processes, merged by seed."""
