"""The package's Python passes flake8, run as ROS 2 packages run it
(ament_flake8), with lines of up to 120 characters."""
from pathlib import Path

import pytest
from ament_flake8.main import main_with_errors


@pytest.mark.flake8
@pytest.mark.linter
def test_flake8():
    package = Path(__file__).resolve().parents[1]
    rc, errors = main_with_errors(argv=["--linelength", "120", str(package)])
    assert rc == 0, f"{len(errors)} code style errors:\n" + "\n".join(errors)
