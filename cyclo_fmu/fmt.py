"""Small text formatters shared by the command line and the diagnosis report."""
from __future__ import annotations

#: Units that mean "dimensionless": printed as nothing after the number (``p = 0.667``, not
#: ``p = 0.667 1``).
DIMENSIONLESS = ("1", "", "-")


def unit_suffix(unit) -> str:
    """`` unit`` to print after a number, or ``""`` for a dimensionless quantity; a
    dimensionless rate keeps its denominator (``"1 per 10 K"`` -> ``" per 10 K"``)."""
    text = "" if unit is None else str(unit).strip()
    if text in DIMENSIONLESS:
        return ""
    if text.startswith("1 per "):
        return " " + text[2:]
    return f" {text}"


def friction_level_fields(profile: str) -> str:
    """The sliding-friction coefficients a diagnosis' friction level scales in ``profile``
    (as ``model_core.design.scale_friction_level`` does): the paper profile's Benedict-Kelley
    clamp, the physical profile's pin boundary coefficient and tooth traction."""
    return "mu_boundary" if profile == "paper" else "mu_pin_boundary, mu_tooth"
