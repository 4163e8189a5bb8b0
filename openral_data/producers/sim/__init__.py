"""Simulated producers, one module per backend."""
