"""openral-data's own per-frame dataset columns (`openral.*` feature keys), each with its one kind: the vocabulary
the run side writes (policies/intervention.py's takeovers) and the tools read (convert, `stats`, the MCAP export),
kept at the bottom of the layers so that no reader imports a producer to name a column."""

from __future__ import annotations

from typing import Literal

POLICY_ACTION = "openral.policy_action"  # the policy's proposal, also while a person drives (the action's names)
INTERVENTION = "openral.intervention"  # a person drove this frame (shape [1])

# the `openral.*` names a per-frame column may take, each with the one dtype it has (`stats` reads the flag as a
# bool); every other `openral.*` name is ours too (the episode columns of meta/episodes)
FRAME_COLUMNS: dict[str, Literal["float32", "bool"]] = {INTERVENTION: "bool", POLICY_ACTION: "float32"}
