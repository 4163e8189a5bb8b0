"""Robots behind the HAL: the protocol (`HalBase`), the MuJoCo twin and a sim scene as a HAL, lerobot hardware, and
the safety filter every command passes through. A new robot driver goes here."""
