"""Hardware abstraction layer: robots (real or simulated) behind one protocol, recorded at a fixed rate."""
