"""model_core: load-dependent power losses and efficiency of the constrained cycloid drive.

Physics of Mackic et al., "Analysis of Power Losses in Constrained Cycloid Drive", with its
typos corrected. Pure numpy/scipy; nothing here knows about FMI.

Rooms: design (data), kinematics, geometry, contact, velocities, friction, losses, efficiency,
maps. Quick start::

    from model_core import DriveDesign, operating_point, rpm_to_rad_s
    op = operating_point(DriveDesign(), "S1", rpm_to_rad_s(2800), 0.8)
    op.eta, op.eta0, op.losses.as_dict()
"""
from .design import DriveDesign, Friction, Lubricant, design_from_toml, design_to_toml
from .efficiency import OperatingPoint, kreines_efficiency, operating_point
from .errors import CycloidInputError
from .kinematics import MODES, rad_s_to_rpm, rpm_to_rad_s, shaft_speeds, speed_ratio
from .losses import LOSS_NAMES, PartialLosses, partial_losses, partial_losses_by_position
from .maps import efficiency_map
from . import discovered, effects, lossmap, rig

__all__ = [
    "DriveDesign", "Friction", "Lubricant", "design_from_toml", "design_to_toml",
    "OperatingPoint", "kreines_efficiency", "operating_point", "CycloidInputError",
    "MODES", "rad_s_to_rpm", "rpm_to_rad_s", "shaft_speeds", "speed_ratio",
    "LOSS_NAMES", "PartialLosses", "partial_losses", "partial_losses_by_position",
    "efficiency_map", "discovered", "effects", "lossmap", "rig",
]
