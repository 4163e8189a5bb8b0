"""MimicGen-style generation as a policy: source demonstrations, cut into object-centric segments (`plan`), played
again with every segment moved to where its object is now (`policy`); `openral-data generate` builds the plan
and records with it (openral_data/generate)."""

from openral_data.policies.mimicgen.plan import Demo, Plan, Segment, read_plan, write_plan
from openral_data.policies.mimicgen.policy import MimicGenPolicy

__all__ = ["Demo", "MimicGenPolicy", "Plan", "Segment", "read_plan", "write_plan"]
