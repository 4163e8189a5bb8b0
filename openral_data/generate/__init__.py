"""`openral-data generate`: many demonstrations from a few, MimicGen-style (docs/generate.md).

`generate(GenerateOptions(...))` replays the source's successful episodes, cuts them into object-centric segments
and records `n` attempts on a scene with the `mimicgen` policy (openral_data/policies/mimicgen), keeping the
episodes that succeed."""

from openral_data.generate.run import GenerateOptions, GenerateSummary, build_plan, generate

__all__ = ["GenerateOptions", "GenerateSummary", "build_plan", "generate"]
