"""Who drives a recording: the choice (choice.py, made once from the options), one module per kind (rskill,
checkpoint, person, leader, takeover), the table that opens them (kinds.py) and the names an episode's record
gives its driver (names.py: `policy:`, `script:`, `teleop:`). A new teleop device goes to producers/hal/teleop/
(devices.py lists them)."""
