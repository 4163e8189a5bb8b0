"""ManiSkill3 tabletop tasks (mani-skill 3.0.1 on SAPIEN 3.0.3, CPU simulation; .venv-maniskill)."""
