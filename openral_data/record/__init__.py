"""Recording: options, the output folder's lifecycle (fresh / resume / lock), the dataset bridge, the scene and
rSkill registry, compatibility checks, sink selection, the sim and HAL episode loops, and parallel recording."""
