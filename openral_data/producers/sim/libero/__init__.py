"""LIBERO (hf-libero 0.1.4 on robosuite 1.4.0) scenes; needs the `libero` extra in its own environment."""
