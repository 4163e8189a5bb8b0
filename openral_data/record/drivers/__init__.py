"""Who drives a recording: the choice (choice.py, made once from the options), one module per kind (rskill,
checkpoint, person, leader, takeover) and the table that opens them (kinds.py). A new teleop device goes to
producers/hal/teleop/ (devices.py lists them)."""
