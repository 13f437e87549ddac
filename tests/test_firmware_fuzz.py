"""The firmware's receive path and protocol parser under a coverage-guided
fuzzer (firmware/fuzz/fuzz_protocol.c), with AddressSanitizer and
UndefinedBehaviorSanitizer: no crash, no hang, no out-of-bounds access, and
every reply line correctly checksummed, over tens of thousands of mutated
inputs grown from valid machine lines.

gcc has no libFuzzer, so the harness carries a small fuzzer of its own fed by
gcc's -fsanitize-coverage=trace-pc; with clang the same file builds under
libFuzzer (see its header).
"""
import shutil
import subprocess

import pytest

from firmware_build import FIRMWARE, host_library

CORE = ["hal/host/core_api.c", "core/stepper.c", "core/planner.c", "core/protocol.c", "core/serial.c", "core/follow.c",
        "build/ramp_table.c"]
SANITIZE = ["-fsanitize=address,undefined", "-fno-sanitize-recover=all",
            "-fno-omit-frame-pointer"]


@pytest.fixture(scope="module")
def fuzzer(tmp_path_factory):
    if shutil.which("gcc") is None:
        pytest.skip("gcc not installed")
    host_library()                      # also generates build/ramp_table.c
    out = tmp_path_factory.mktemp("fuzz")
    objects = []
    for src in CORE:
        obj = out / (src.replace("/", "_") + ".o")
        subprocess.run(["gcc", "-c", "-g", "-O1", "-std=c99", *SANITIZE, "-fsanitize-coverage=trace-pc",
                        "-Icore", src, "-o", str(obj)], cwd=FIRMWARE, check=True)
        objects.append(str(obj))
    exe = out / "fuzz_protocol"
    subprocess.run(["gcc", "-g", "-O1", "-std=gnu99", "-Wall", "-Wextra", "-Werror", "-DFUZZ_MAIN", *SANITIZE,
                    "fuzz/fuzz_protocol.c", *objects, "-o", str(exe)], cwd=FIRMWARE, check=True)
    return exe


@pytest.mark.parametrize("seed", [1, 2])
def test_protocol_parser_survives_fuzzing(fuzzer, seed):
    run = subprocess.run([str(fuzzer), "30000", str(seed)], capture_output=True, text=True, timeout=300,
                         env={"ASAN_OPTIONS": "detect_leaks=0:abort_on_error=1",
                              "UBSAN_OPTIONS": "print_stacktrace=1:halt_on_error=1"})
    assert run.returncode == 0, run.stdout + run.stderr
    assert "30000 inputs" in run.stdout
    edges = int(run.stdout.split()[-3])
    assert edges > 300, f"the fuzzer reached little of the parser: {run.stdout}"

