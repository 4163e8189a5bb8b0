"""`openral-data pipeline run FILE.yaml`: declarative, resumable campaigns (record, merge, replay, stats, export)."""
