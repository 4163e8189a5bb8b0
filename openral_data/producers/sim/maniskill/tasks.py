"""The ManiSkill3 tabletop tasks that run offline (their objects are built from primitives or ship in the wheel),
each with an instruction written from the task's success condition (ManiSkill has no language of its own), and
whether mani_skill.examples.motionplanning has a solution (a scripted expert) for it.

Not here: PickSingleYCB, PickClutterYCB, AssemblingKits, TurnFaucet (their assets are downloaded at run time),
PushT (the panda_stick robot), the two-robot tasks (two action vectors).
"""

from __future__ import annotations

from dataclasses import dataclass

from openral_data.producers.sim.tasks import SuiteTask
from openral_data.schemas.scene import SimScene


@dataclass(frozen=True)
class ManiSkillTask:
    env_id: str
    instruction: str
    expert: str | None  # the motion-planning solution's name in mani_skill.examples.motionplanning.panda.solutions


TASKS: tuple[ManiSkillTask, ...] = (
    ManiSkillTask("PickCube-v1", "pick up the red cube and move it to the green goal", "solvePickCube"),
    ManiSkillTask("PushCube-v1", "push the cube into the red and white target", "solvePushCube"),
    ManiSkillTask("StackCube-v1", "stack the red cube on the green cube", "solveStackCube"),
    ManiSkillTask("PullCube-v1", "pull the cube onto the red and white target", "solvePullCube"),
    ManiSkillTask("LiftPegUpright-v1", "lift the peg lying on the table upright", "solveLiftPegUpright"),
    ManiSkillTask(
        "PegInsertionSide-v1", "insert the peg into the hole of the box from the side", "solvePegInsertionSide"
    ),
    ManiSkillTask("PlaceSphere-v1", "place the sphere into the bin", "solvePlaceSphere"),
    ManiSkillTask("PullCubeTool-v1", "pull the cube closer with the L-shaped tool", "solvePullCubeTool"),
    ManiSkillTask("PlugCharger-v1", "plug the charger into the receptacle", "solvePlugCharger"),
    ManiSkillTask("StackPyramid-v1", "stack the three cubes into a pyramid", "solveStackPyramid"),
    ManiSkillTask("PokeCube-v1", "push the cube to the goal with the peg", None),
    ManiSkillTask("RollBall-v1", "roll the ball to the goal region", None),
)
BY_ID = {t.env_id: t for t in TASKS}


def suite_tasks(scene: SimScene, source: str) -> list[SuiteTask]:
    """Every offline ManiSkill3 tabletop task (`--task StackCube-v1`), the scene's own first."""
    own = scene.scene.params.get("env_id")
    ordered = sorted(TASKS, key=lambda t: t.env_id != own)
    return [SuiteTask(t.env_id, t.instruction, {"env_id": t.env_id}) for t in ordered]
