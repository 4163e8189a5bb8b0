"""Dataset and replay metrics: DuckDB views over LeRobot v3 parquet in place, intervals, health checks."""
