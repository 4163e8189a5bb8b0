"""The rollout runtime the tools share (`record`, `convert`, `replay`, `pipeline`, the Python API, `list`).

* `bridge`: the dataset bridge, which checks every frame against the rSkill's contract and feeds the sinks;
* `registry`: the scene-type and policy registries (open to plug-ins), robots, scene and rSkill references;
* `tasks`: the tasks of suite scenes (`--task`) and the instruction a run records (`--instruction`);
* `catalog`: what this installation knows (`list`), and where each item comes from;
* `compat`: robot / rSkill / scene compatibility, checked before episode 0;
* `available`: which scenes and rSkills can run in this environment, and why not (`list`'s `runs here`);
* `schema`: a run's dataset schema and provenance metadata (record, record --hal, replay --record);
* `sinks`: the output formats a run writes (LeRobot v3, MCAP) and their settings;
* `observers`: frame observers beside the sinks (debug videos, the live rerun view);
* `outdir`: output folders (a fresh default name, refusing an `--out` that holds something);
* `parallel`: running jobs in worker processes or on Ray (`record --workers`, `convert --workers`).

The runtime sits below the tools and above policies and producers; the `record` command itself lives in
`openral_data.record`. The modules are not imported here, so using one never loads the others' libraries.
"""

__all__ = [
    "available",
    "bridge",
    "catalog",
    "compat",
    "observers",
    "outdir",
    "parallel",
    "registry",
    "schema",
    "sinks",
    "tasks",
]
