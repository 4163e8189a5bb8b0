"""A policy whose id clashes with the built-in `random` (reported, ignored) and a robots folder that is not there."""

MISSING_ROBOTS = "/nonexistent/openral-broken-plugin/robots"


def random_policy(rskill: object) -> object:
    raise AssertionError("a plug-in must never replace a built-in policy")
