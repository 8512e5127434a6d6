"""Small text formatters shared by the command line and the diagnosis report."""
from __future__ import annotations

#: Units that mean "dimensionless": printed as nothing after the number (``p = 0.667``, not
#: ``p = 0.667 1``).
DIMENSIONLESS = ("1", "", "-")


def unit_suffix(unit) -> str:
    """`` unit`` to print after a number, or ``""`` for a dimensionless quantity."""
    return "" if unit is None or str(unit).strip() in DIMENSIONLESS else f" {unit}"


def friction_level_fields(profile: str) -> str:
    """The sliding-friction coefficients a diagnosis' friction level scales in ``profile``
    (as ``model_core.design.scale_friction_level`` does): the paper profile's Benedict-Kelley
    clamp, the physical profile's pin boundary coefficient and tooth traction."""
    return "mu_boundary" if profile == "paper" else "mu_pin_boundary, mu_tooth"
