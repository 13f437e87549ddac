/* config.h - build-time sizes and constants shared by the core and both HALs. */
#ifndef CONFIG_H
#define CONFIG_H

#include <stdint.h>

#define FW_NAME     "PLOTTER 8051"
#define FW_VERSION  "1.0"

/* STC89C52RC at 11.0592 MHz, 12 clocks per machine cycle; 6 with CPU_6T
 * (the chip's double-speed mode, an option byte set when it is programmed:
 * make CPU6T=1, README.md). */
#ifdef CPU_6T
#define CYCLES_PER_S  1843200UL
#define DWELL_PERIOD  1843u         /* one millisecond in machine cycles */
#else
#define CYCLES_PER_S  921600UL
#define DWELL_PERIOD  922u          /* one millisecond in machine cycles */
#endif

#define QUEUE_SIZE  6               /* motion segments buffered ahead */
#define RX_SIZE     64              /* UART receive ring (power of two) */
#define TX_SIZE     16              /* UART transmit ring (power of two) */
#define LINE_MAX    48              /* longest accepted command line, without newline */

/* Real-time bytes acted on by the receive interrupt, never queued. */
#define RT_STATUS  '?'
#define RT_HOLD    '!'
#define RT_RESUME  '~'
#define RT_RESET   0x18             /* Ctrl-X */
#define RT_ESTOP   0x1B             /* ESC */

/* Interpolation (build option INTERP, README.md): point-by-point comparison
 * unless INTERP_DDA (digital differential analyser) or INTERP_COMPARE
 * (comparison-integration) is defined; those two may move both axes in one
 * step. */
#if defined(INTERP_DDA) || defined(INTERP_COMPARE)
#define INTERP_DIAGONAL 1
#endif

/* The front panel (README.md: keypad, LCD, 7-segment display, built-in
 * figures, e-stop and limit inputs, core/panel.h): PANEL is defined for the
 * board's image, which has it beside the whole host link, and not for the
 * option images, which use its pins. */
#ifdef PANEL
#define RT_STAR     'a'             /* real-time byte between lines: draw the star (seed 000, 4.3) */
#endif

/* The host link's two sequence counters (planner.h, protocol.c) sit where
 * the image has room: internal RAM is full in the board's image, XRAM in the
 * comparison-integration one (its queue_final, planner.c). */
#ifdef INTERP_COMPARE
#define SEQ_MEM IDATA
#else
#define SEQ_MEM XDATA
#endif

#if defined(DRIVE_PHASE3) || defined(DRIVE_PHASE3D) || defined(DRIVE_UNIPOLAR)
/* Direct phase drive (build option DRIVE, README.md): the X windings on
 * P1 from P1.0, the Y windings on P2 from P2.0, the pen on P1.4 as in the
 * step/direction build.  The port byte st_port holds the X winding pattern
 * in PHASE_BITS; its direction bits are the interrupt's own state (their
 * pins show it, the motors do not need it). */
#define DRIVE_PHASE 1
#ifdef DRIVE_UNIPOLAR
#define PHASE_BITS  0x0F            /* windings A, B, A', B' on P1.0-P1.3 (P2.0-P2.3) */
#define BIT_X_DIR   0x20
#define BIT_Y_DIR   0x40
#else
#define PHASE_BITS  0x07            /* windings A, B, C on P1.0-P1.2 (P2.0-P2.2) */
#define BIT_X_DIR   0x08
#define BIT_Y_DIR   0x20
#endif
#define PHASE_START 0x01            /* winding A energised at power-on */
#define BIT_PEN     0x10            /* set: pen down */
#else
/* Output bits of the step/direction port (P1 on the 8051 board). */
#define BIT_X_STEP  0x01
#define BIT_X_DIR   0x02            /* set: moving towards -X */
#define BIT_Y_STEP  0x04
#define BIT_Y_DIR   0x08            /* set: moving towards -Y */
#define BIT_PEN     0x10            /* set: pen down */
#define STEP_BITS   (BIT_X_STEP | BIT_Y_STEP)
#ifdef ZAXIS
/* The Z axis (build option ZAXIS, README.md): its own step and direction. */
#define BIT_Z_STEP  0x20
#define BIT_Z_DIR   0x40            /* set: moving towards -Z */
#endif
#endif

#endif
