"""`record/driver.SCRIPTED_POLICIES` names built-in policies of `runtime.registry.POLICIES` (record sits above
runtime, but which policy is a program and which a model is not something the registry says): the two agree,
and a built-in added to the registry must be put on one side or the other here."""

from __future__ import annotations

from openral_data.record.drivers.names import SCRIPTED_POLICIES
from openral_data.runtime.registry import POLICIES

MODELS = frozenset({"zero", "random", "lerobot"})  # built-ins that are no hand-written program: `policy:<id>`


def test_scripted_policies_are_built_ins_of_the_registry() -> None:
    built_in = {name for name in POLICIES if POLICIES.origin(name) == "built-in"}
    assert built_in >= SCRIPTED_POLICIES, sorted(SCRIPTED_POLICIES - built_in)
    assert built_in == SCRIPTED_POLICIES | MODELS, sorted(built_in ^ (SCRIPTED_POLICIES | MODELS))
