"""The single error type raised for malformed BDDL (defined with the project's other errors)."""

from libero_data.errors import BDDLError

__all__ = ["BDDLError"]
