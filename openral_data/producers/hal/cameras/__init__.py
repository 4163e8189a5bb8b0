"""Cameras a HAL reads: the sample/sensor protocol, polled and threaded capture, lerobot cameras and RealSense
depth. A new camera goes here."""
