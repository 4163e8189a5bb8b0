"""Simulated producers, one module per backend (mock, mujoco/ tabletop scenes, robosuite, MetaWorld, gym-aloha,
gym-pusht, libero/), and what they share: scene params (params.py), the spec and rSkill contract checks
(contract.py), a simulator's own cameras (named_cameras.py, external.py), the checks on a recorded initial state
(initial_state.py) and MuJoCo state snapshots (mjstate.py)."""
