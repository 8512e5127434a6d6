"""Hostile hosts in C for the sanitizer run (cyclo_fmu.native.sanitize)."""
