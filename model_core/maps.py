"""Maps: efficiency and partial losses over a grid of input speed x input torque."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .efficiency import operating_point


@dataclass(frozen=True)
class EfficiencyMap:
    """Efficiency and losses on a speed x torque grid; arrays shaped (n_speed, n_torque)."""

    mode: str
    speeds: np.ndarray      # input speeds, rad/s
    torques: np.ndarray     # input torques, N*m
    eta: np.ndarray
    eta0: np.ndarray
    locked: np.ndarray
    losses: dict            # name -> array, W
    input_power: np.ndarray


def efficiency_map(design, mode, speeds, torques, dedup=True) -> EfficiencyMap:
    """Evaluate the drive on the grid speeds x torques (1-D arrays, rad/s and N*m), every point
    mesh-cycle averaged with its contacts solved; one vectorised pass (``dedup``: see
    efficiency.operating_point)."""
    speeds = np.asarray(speeds, float)
    torques = np.asarray(torques, float)
    W, T = np.meshgrid(speeds, torques, indexing="ij")
    op = operating_point(design, mode, W, T, dedup=dedup)
    return EfficiencyMap(mode=op.mode, speeds=speeds, torques=torques, eta=op.eta, eta0=op.eta0,
                         locked=op.locked, losses=op.losses.as_dict(), input_power=op.input_power)
