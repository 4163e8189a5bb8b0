"""The package version, in one place (pyproject.toml's `version` must equal it; tests/test_api.py checks)."""

__version__ = "0.1.0"
