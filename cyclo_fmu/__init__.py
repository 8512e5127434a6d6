"""cyclo_fmu: the cycloid-drive physics core as tools for drivetrain engineers (command line
``cyclo-fmu``; FMI components, bench and diagnosis follow)."""
__version__ = "0.1.0"
