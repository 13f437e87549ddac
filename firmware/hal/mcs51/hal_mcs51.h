/* hal_mcs51.h - the core's hardware layer on the STC89C52RC.
 * Timer 2 (Timer 0 in the option images and with BAUD=115200; their
 * priorities: IP in main.c) paces the steps; port 1 carries step,
 * direction and pen outputs (firmware/README.md has the pin map). */
#ifndef HAL_MCS51_H
#define HAL_MCS51_H

#include <8052.h>
#include <stdint.h>

#define FAST __data
#define ROM __code
/* C99 inline without extern: SDCC expands it and emits no unused copy. */
#define INLINE inline
/* The on-chip XRAM as __pdata: MOVX @Ri, one byte shorter than a DPTR load
 * and no DPH to set, which the STC89C52RC's 256 bytes of XRAM answer at Ri
 * whatever P2 holds (the keypad and the phase drives write P2).  s51 is set
 * up the same way (tools/s51sim.py). */
#define XDATA __pdata
#define IDATA __idata
/* Flags live in the bit-addressable RAM: setb/clr/jb are one instruction each. */
#define FLAG __bit

/* hal_putc saves the registers it uses, so callers keep their values in
 * registers across the (many) calls instead of spilling them to RAM. */
#pragma callee_saves hal_putc

#ifdef DRIVE_PHASE
/* P1: X windings, the pen on P1.4, and the direction bits of st_port (the
 * interrupt's own state, seen on their pins but wired to nothing); the
 * other pins are inputs, written high.  P2: Y windings, the rest high. */
#define HAL_PORT_IDLE ((uint8_t)(PHASE_START | (uint8_t)~(PHASE_BITS | BIT_PEN | BIT_X_DIR | BIT_Y_DIR)))
#define HAL_PORT_OUT(v) (P1 = (v))
#define HAL_PORT2_OUT(v) (P2 = (uint8_t)((v) | (uint8_t)~PHASE_BITS))
#elif defined(ZAXIS)
/* P1.5, P1.6: Z step and direction; P1.7 is an input, written high. */
#define HAL_PORT_IDLE 0x80
#define HAL_PORT_OUT(v) (P1 = (v))
#else
/* P1.5-P1.7 are inputs (X limit, spare, Y limit): keep them written high. */
#define HAL_PORT_IDLE 0xE0
#define HAL_PORT_OUT(v) (P1 = (v))
#endif

#ifdef PANEL
/* Limit switches close to ground.  P1.5 >> 4 is BIT_X_DIR, P1.7 >> 4 BIT_Y_DIR:
 * the closed switches as the direction bits that head for them. */
#define HAL_LIMITS_CLOSED() ((uint8_t)((uint8_t)~P1 >> 4))
#define HAL_ESTOP_ACTIVE() (!P3_2)          /* e-stop button on P3.2 (INT0), closes to ground */
/* LCD: data bus P0, RS P3.3, E P3.4, R/W tied low.  7-segment display:
 * segments on P0 as well (the LCD only takes P0 on E's falling edge), the
 * digit through a 74HC138 on P3.5-P3.7.  All written a byte at a time
 * (orl/anl on the port latch), so the simulator's VCD records every edge. */
#define LCD_RS 0x08
#define LCD_E  0x10
#define SEG_SELECT 0xE0
void hal_lcd_write(uint8_t b);
uint8_t hal_key_scan(void);
/* rs is the literal 0 (a command) or 1 (data): RS is set by one orl or anl. */
#define HAL_LCD_WRITE(b, rs) do { HAL_LCD_RS_##rs(); hal_lcd_write(b); } while (0)
#define HAL_LCD_RS_0() (P3 &= (uint8_t)~LCD_RS)
#define HAL_LCD_RS_1() (P3 |= LCD_RS)
#define HAL_KEY_SCAN() hal_key_scan()
#define HAL_SEG_SHOW(i, pattern) do {                                       \
        P0 = 0;                                                             \
        P3 &= (uint8_t)~SEG_SELECT;                                         \
        P3 |= (uint8_t)((i) << 5);                                          \
        P0 = (pattern);                                                     \
    } while (0)
#endif

#ifdef STEPPER_ASM
/* The board's image: the step interrupt is hal/mcs51/stepper_isr.asm, the
 * C one of core/stepper.c by hand (tests/test_firmware_asm_equivalence.py
 * holds them equal pulse for pulse), on Timer 2 in 16-bit auto-reload: the
 * period sits in RCAP2 and the timer reloads it at each overflow, so a step
 * costs no reload instructions and the pulses keep to the overflows.  The
 * interrupt writes RCAP2 whenever the period changes: the overflow that
 * follows takes it, which is the schedule HAL_TIMER_ADVANCE gives. */
#define HAL_STEPPER_ISR_EXTERNAL 1
extern volatile __bit st_fast;      /* the interrupt's fast paths: a line cruising, */
extern volatile __bit st_rampfast;  /* a line on the ramp, */
extern volatile __bit st_arcfast;   /* an arc cruising; none of them tests the hold */
#define HAL_STEPPER_SLOW() (st_fast = 0, st_rampfast = 0, st_arcfast = 0)
__sfr16 __at(0xCBCA) RCAP2;
__sfr16 __at(0xCDCC) TMR2;
#define HAL_STEP_PERIOD RCAP2
#define HAL_PERIOD(p) ((uint16_t)(0 - (uint16_t)(p)))
#define HAL_PERIOD_LONGER(a, b) ((uint16_t)(a) < (uint16_t)(b))
#define STEPPER_ISR void stepper_isr(void) __interrupt(5) __naked
#define HAL_TIMER_START(p) do {                                              \
        TR2 = 0;                                                             \
        TMR2 = (uint16_t)(0 - (uint16_t)(p));                                \
        TF2 = 0;                                                             \
        TR2 = 1;                                                             \
    } while (0)
#define HAL_TIMER_HALT() do { TR2 = 0; TF2 = 0; } while (0)
#else
/* Timer 0 as one 16-bit register (TH0:TL0). */
__sfr16 __at(0x8C8A) TMR0;

/* Machine cycles the timer misses while HAL_TIMER_ADVANCE has it stopped
 * (from `clr TR0` to `setb TR0`; tests/test_firmware_sim.py checks in s51
 * that cruise pulses come exactly one period apart). */
#define TIMER_STOPPED_CYCLES 9

/* A step period as HAL_TIMER_ADVANCE takes it: the value that, added to the
 * timer a few cycles after its overflow, makes it overflow again p cycles
 * after that overflow.  Tables and the planner store periods in this form so
 * that the interrupt only adds. */
#define HAL_PERIOD(p) ((uint16_t)(TIMER_STOPPED_CYCLES - (uint16_t)(p)))
/* The longer of two periods has the smaller timer value (for periods of
 * more than TIMER_STOPPED_CYCLES, as every step period is). */
#define HAL_PERIOD_LONGER(a, b) ((uint16_t)(a) < (uint16_t)(b))

#define STEPPER_ISR void stepper_isr(void) __interrupt(1) __using(1)

/* Schedule the next interrupt r = HAL_PERIOD(p) after the overflow that
 * raised this one: add r to the stopped timer.  A carry out means the
 * moment has passed already (this interrupt started late, or the step rate
 * is more than the CPU can do): then fire again at once rather than a whole
 * timer turn later.  Assembler because it runs once per step: 12 cycles,
 * where SDCC's code for the same took 21.  r must be a 16-bit variable in
 * direct RAM.  Interrupts are masked while the timer is stopped: the UART
 * and the e-stop interrupt this one (IP, main.c), and a halt of theirs
 * (HAL_TIMER_HALT) between the clr and the setb would be undone. */
#define HAL_TIMER_ADVANCE(r) __asm__(                                        \
        "\tclr\t_EA\n"                                                       \
        "\tclr\t_TR0\n"                                                      \
        "\tmov\ta,_TL0\n"                                                    \
        "\tadd\ta,_" #r "\n"                                                  \
        "\tmov\t_TL0,a\n"                                                    \
        "\tmov\ta,_TH0\n"                                                    \
        "\taddc\ta,(_" #r " + 1)\n"                                           \
        "\tmov\t_TH0,a\n"                                                    \
        "\tjnc\t.+8\n"                                                       \
        "\tmov\t_TL0,#0xff\n"                                                \
        "\tmov\t_TH0,#0xff\n"                                                \
        "\tsetb\t_TR0\n"                                                     \
        "\tsetb\t_EA\n")
#define HAL_TIMER_START(p) do {                                              \
        TR0 = 0;                                                             \
        TMR0 = (uint16_t)(0 - (uint16_t)(p));                                \
        TF0 = 0;                                                             \
        TR0 = 1;                                                             \
    } while (0)
#define HAL_TIMER_HALT() do { TR0 = 0; TF0 = 0; } while (0)
#endif
#ifndef HAL_STEPPER_SLOW
#define HAL_STEPPER_SLOW()
#endif
/* 16 x 16 -> 32-bit products by hal/mcs51/mul16.asm (four MUL AB, not the
 * library's 32 x 32 multiply). */
uint32_t mul16u(uint16_t a, uint16_t b);
uint32_t mul16s(int16_t a, int16_t b);
#define HAL_MUL16U(a, b) mul16u(a, b)
#define HAL_MUL16S(a, b) mul16s(a, b)
#ifdef FOLLOW
/* *p, a little-endian number of n bytes in XRAM, plus v: hal/mcs51/add8.asm. */
void add8(XDATA uint8_t *p, int8_t v, uint8_t n);
#define HAL_ADD8(p, v, n) add8(p, v, n)
#endif
#define HAL_SEGMENT_STARTED(s)
/* Line following (FOLLOW; the image has no keypad, whose P2 it takes):
 * the three sensors' comparators on P2.0-P2.2, low over black; the follow
 * key on P2.3, to ground. */
#define HAL_SENSORS() ((uint8_t)(~P2 & 0x07))
#define HAL_FOLLOW_KEY() (!(P2 & 0x08))
#define HAL_CRITICAL_BEGIN() (EA = 0)
#define HAL_CRITICAL_END() (EA = 1)

#endif
