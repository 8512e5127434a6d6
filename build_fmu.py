"""Build the FMUs into dist/: python build_fmu.py [--dest DIR] [NAME ...]"""
import sys

from cyclo_fmu.fmu_build import main

if __name__ == "__main__":
    sys.exit(main())
