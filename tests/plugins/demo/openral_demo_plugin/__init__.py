"""openral-demo-plugin: a 1-D slider scene, a P controller and their manifests (scenes/, rskills/, robots/)."""
