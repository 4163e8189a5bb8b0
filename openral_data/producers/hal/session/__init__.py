"""The operator of a recording session: the verdict keys (start, success, failure, discard, re-record, quit,
e-stop) from a terminal or a script."""
