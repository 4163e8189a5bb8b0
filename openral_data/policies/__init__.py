"""rSkill policy adapters."""

from openral_data.policies.base import PolicyAdapter

__all__ = ["PolicyAdapter"]
