"""Devices a person drives a robot with: the keyboard, a leader arm, an evdev gamepad and a hidraw SpaceMouse (the
end-effector devices share eef_device.py). A new device is one module here plus its line in `devices.DEVICES`."""
