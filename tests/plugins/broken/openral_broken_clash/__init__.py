"""A policy whose id clashes with the built-in `random`: reported, ignored."""


def random_policy(rskill: object) -> object:
    raise AssertionError("a plug-in must never replace a built-in policy")
