/* hal.h - selects the hardware layer: the 8051 board under SDCC, the host
 * simulation under gcc.  The core only uses the macros listed here:
 *   FAST, IDATA, XDATA    storage classes (direct / indirect internal RAM, the on-chip XRAM)
 *   ROM                   storage class of constant tables and strings (program memory)
 *   FLAG                  type of a one-bit flag (a bit variable on the 8051)
 *   STEPPER_ISR           definition line of the step timer interrupt
 *   HAL_PERIOD(p)         a step period of p machine cycles in the timer's own form
 *   HAL_PERIOD_LONGER(a, b)  periods a and b in that form: a lasts longer than b
 *   HAL_TIMER_ADVANCE(r)  schedule the next step interrupt one period r = HAL_PERIOD(p)
 *                         after the one being served
 *   HAL_TIMER_START(p)    start the step timer, first interrupt after p cycles
 *   HAL_TIMER_HALT()      stop the step timer at once and drop a pending tick
 *   HAL_PORT_OUT(v)       write the step/direction/pen port (a byte-wide write)
 *   HAL_PORT2_OUT(v)      phase drive only: write the Y windings' port
 *   HAL_SEGMENT_STARTED(s) a queued command with sequence number s begins
 *   HAL_STEPPER_SLOW()    the next step takes the interrupt's full path (the
 *                         motion is forgotten, or a feed hold comes): for the
 *                         fast-path flags a hand-written interrupt keeps
 *   HAL_MUL16U(a, b), HAL_MUL16S(a, b)  the 32-bit product of two 16-bit
 *                         values, unsigned or signed (as uint32_t)
 *   HAL_ADD8(p, v, n)     optional: *p, a little-endian number of n bytes in
 *                         XDATA, plus the signed byte v (else follow.c's C loop)
 *   HAL_CRITICAL_BEGIN/END mask interrupts around a multi-byte read
 *   INLINE                a function expanded where used, with no separate copy */
#ifndef HAL_H
#define HAL_H

#ifdef __SDCC
#include "../hal/mcs51/hal_mcs51.h"
#else
#include "../hal/host/hal_host.h"
#endif

void hal_putc(uint8_t c);   /* queue one byte for the UART */

#endif
