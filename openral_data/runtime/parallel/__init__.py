"""Parallel runs, in one home: `choice` (one process or N), `workdir` (the workers' folders beside the output),
`executors` (jobs in worker processes or Ray tasks, results as they finish), `channel` (the signals a parent
holds around its workers, a worker's progress reports back) and `shards` (the workers' datasets merged into one)."""

__all__ = ["channel", "choice", "executors", "shards", "workdir"]
