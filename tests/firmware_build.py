"""Builds the firmware's host library once per test session."""
import subprocess
from functools import lru_cache
from pathlib import Path

REPO_ROOT = Path(__file__).resolve().parent.parent
FIRMWARE = REPO_ROOT / "firmware"


@lru_cache(maxsize=None)
def host_library() -> Path:
    subprocess.run(["make", "-s", "-C", str(FIRMWARE), "build/libplotter_core.so"], check=True)
    return FIRMWARE / "build" / "libplotter_core.so"
