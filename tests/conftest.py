import pytest

from model_core import DriveDesign


@pytest.fixture(scope="session")
def design():
    """The paper's test drive (Table 3) with the documented assumptions."""
    return DriveDesign()
