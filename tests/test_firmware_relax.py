"""firmware/tools/relax.py: which calls and jumps it shortens, and how it
finds the ones that must stay long (their target in another 2 KB page).

The image it links is tested by everything that runs it in s51; here, the
rules themselves, on small made-up listings, and on the board's image: no
short call or jump in it leaves its page, and the code areas with a fixed
layout keep their long forms.
"""
import sys

import pytest

from firmware_build import FIRMWARE, mcu_image, require_s51

sys.path.insert(0, str(FIRMWARE / "tools"))
import relax  # noqa: E402

SOURCE = """\
\t.area HOME    (CODE)
__interrupt_vect:
\tljmp\t__sdcc_gsinit_startup
\t.area GSFINAL (CODE)
\tljmp\t__sdcc_program_startup
\t.area CSEG    (CODE)
_f:
\tlcall\t_g\t; ljmp in a comment
00101$:\tljmp\t00102$
\tsjmp\t00101$
00102$:
\tret
"""


def test_only_cseg_calls_and_jumps_are_candidates():
    lines = SOURCE.splitlines()
    got = relax.candidates(SOURCE)
    assert [lines[k].split(";")[0].split() for k in got] == [["lcall", "_g"], ["00101$:", "ljmp", "00102$"]]


def test_jump_table_entries_stay_long():
    """SDCC's switch indexes a table of ljmp in steps of three bytes."""
    source = ("\t.area CSEG    (CODE)\n_f:\n\tmov\tdptr,#00120$\n\tjmp\t@a+dptr\n"
              "00120$:\n\tljmp\t00101$\n\tljmp\t00102$\n00101$:\n\tljmp\t00102$\n00102$:\n\tret\n")
    assert relax.candidates(source) == [8]         # the jump after the table, not its entries


def test_shorten_keeps_labels_and_comments():
    got = relax.shorten(SOURCE, relax.candidates(SOURCE)).splitlines()
    assert got[7] == "\tacall\t_g\t; ljmp in a comment"
    assert got[8] == "00101$:\tajmp\t00102$"
    assert got[2] == "\tljmp\t__sdcc_gsinit_startup"      # HOME: fixed layout


def rst_line(addr, srcno, text, code=""):
    return f"      {addr:06X} {code:<22}[24] {srcno:4d} {text}\n"


def test_out_of_page_by_the_next_instructions_page(tmp_path):
    rst = tmp_path / "m.rst"
    rst.write_text("".join([
        rst_line(0x0100, 1, "_a:"),
        rst_line(0x0100, 2, "\tacall\t_far", "91 00"),          # _far in page 1
        rst_line(0x0102, 3, "00101$:"),
        rst_line(0x0102, 4, "\tajmp\t00101$", "41 02"),         # same page
        rst_line(0x07F0, 5, "_b:"),
        rst_line(0x07FE, 6, "\tajmp\t00101$", "E1 00"),         # next instruction at 0x800
        rst_line(0x0800, 7, "00101$:"),
        rst_line(0x0800, 8, "\tret", "22"),
    ]))
    # Line 4 jumps to the 00101$ after _a, not to the one after _b (sdas's
    # reusable labels live between two ordinary ones), and line 6 may jump
    # to 0x800: the page that counts is that of the instruction after it.
    assert relax.out_of_page(rst, {"_far": 0x0900}) == [2]
    assert relax.out_of_page(rst, {"_far": 0x0100}) == []


def test_board_image_short_forms_stay_in_their_pages():
    require_s51()
    base = mcu_image()
    mcs51 = base.parent / "mcs51"
    globals_ = relax.s51sim.Symbols(base)
    rsts = sorted(mcs51.glob("*.rst"))
    assert rsts
    shortened = 0
    for rst in rsts:
        assert relax.out_of_page(rst, globals_) == [], rst.name
        shortened += sum(1 for line in open(rst) if "\tacall\t" in line or "\tajmp\t" in line)
    assert shortened > 100
    # The step interrupt lies within one page, all its calls and jumps short.
    isr = (mcs51 / "stepper_isr.relax.asm").read_text()
    assert "\tlcall\t" not in isr and "\tljmp\t" not in isr


if __name__ == "__main__":
    sys.exit(pytest.main([__file__]))
