"""Who drove an episode: the `operator` of its `openral.episode_info` (the `episodes` SQL view's `operator`).

`teleop:<device>` when a person drove (`keyboard`, a leader arm's lerobot type such as `so101_leader`),
`script:<rskill id>` when a hand-written program did (the built-in scripted experts and joint sweeps),
`policy:<rskill id>` for every other rSkill (a learned policy, random or zero actions, a plug-in's).
"""

from __future__ import annotations

from openral_data.schemas.rskill import RSkillManifest

# the built-in policies (runtime/registry.py POLICIES) that are programs, not models (the registry does not say
# which; tests/record/test_driver_names.py checks the two agree)
SCRIPTED_POLICIES = frozenset(
    {"scripted_push", "scripted_pick_place", "scripted_pick", "scripted_open_drawer"}
    | {"metaworld_expert", "maniskill_expert", "sweep", "mimicgen"}
)


def rskill_driver(rskill: RSkillManifest) -> str:
    kind = "script" if rskill.policy in SCRIPTED_POLICIES else "policy"
    return f"{kind}:{rskill.id}"


def teleop_driver(device: str) -> str:
    return f"teleop:{device}"
