"""Multi-byte values the step interrupt writes are never read half before and
half after it: on the 8051 a 16-bit read is two instructions, and a segment
load or an underrun between them reports a value that never was.

Checked on the compiled image (SDCC's listings of the default build): every
instruction of the main-loop modules that names such a value lies between a
`clr _EA` and the next `setb _EA`.  The position is read another way
(stepper_snapshot reads until two reads agree) and the step interrupt's own
module is its writer, so neither is listed here.
"""
import re

import pytest

from firmware_build import mcu_image

# The main loop's modules (core/*.c and the board's main.c); stepper.c is the interrupt's.
MAIN_LOOP = ("protocol", "panel", "display", "figures", "planner", "serial", "main")
# 16-bit values written by the step interrupt: st_seg.seq (offset 2 of st_seg) and st_underruns.
SHARED = {"st_seg.seq": re.compile(r"\(_st_seg \+ 0x000[23]\)"), "st_underruns": re.compile(r"#?_st_underruns\b")}


def code_lines(path):
    """(line number, instruction) of an SDCC listing, comments and directives left out."""
    for n, line in enumerate(path.read_text().splitlines(), 1):
        text = line.split(";")[0].strip()
        if text and not text.startswith(".") and not text.endswith("::") and not text.endswith(":"):
            yield n, text


def unmasked_uses(path):
    """Instructions naming a shared value while interrupts are enabled (or not known masked)."""
    masked, found = False, []
    for n, text in code_lines(path):
        if text == "clr\t_EA":
            masked = True
        elif text == "setb\t_EA" or text.startswith("ret"):
            masked = False
        for name, pattern in SHARED.items():
            if pattern.search(text) and not masked:
                found.append(f"{path.name}:{n}: {name}: {text}")
    return found


def test_the_status_reports_16_bit_counters_are_read_with_the_step_interrupt_masked():
    build = mcu_image().parent / "mcs51"
    listings = [build / f"{m}.asm" for m in MAIN_LOOP if (build / f"{m}.asm").exists()]
    assert {p.stem for p in listings} >= {"protocol", "panel", "serial", "planner"}
    uses = [u for p in listings for u in unmasked_uses(p)]
    assert uses == [], "\n".join(uses)
    # ... and the check sees them at all: the status report reads both.
    text = (build / "protocol.asm").read_text()
    assert all(pattern.search(text) for pattern in SHARED.values())


def test_the_check_finds_an_unmasked_read(tmp_path):
    listing = tmp_path / "protocol.asm"
    listing.write_text("_f:\n\tclr\t_EA\n\tmov\tr0,#_st_underruns\n\tsetb\t_EA\n"
                       "\tmov\tdpl,((_st_seg + 0x0002) + 0)\n\tret\n")
    assert unmasked_uses(listing) == ["protocol.asm:5: st_seg.seq: mov\tdpl,((_st_seg + 0x0002) + 0)"]


if __name__ == "__main__":
    pytest.main([__file__])
