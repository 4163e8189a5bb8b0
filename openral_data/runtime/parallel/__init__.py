"""Jobs in worker processes (`spawn`) or Ray tasks, results as they finish: `executors` runs them, `channel`
holds the signals a parent holds around its workers and carries a worker's progress reports back."""

__all__ = ["channel", "executors"]
