"""The reducer as a native FMI 2.0 co-simulation FMU (C, no Python): ``CycloidDriveNative.fmu``.

``build_native_fmu(design, dest)`` exports the design's loss map (all six modes, both flow
directions) into a generated C file and compiles it with the C sources of this package.
"""
from .build import NAME, build_native_fmu, export_map

__all__ = ["NAME", "build_native_fmu", "export_map"]
