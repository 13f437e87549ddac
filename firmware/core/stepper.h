/* stepper.h - the step interrupt: point-by-point comparison interpolation of
 * the queued lines and arcs, the acceleration ramp, and the machine position. */
#ifndef STEPPER_H
#define STEPPER_H

#include "config.h"
#include "hal.h"
#include "segment.h"

/* Absolute position in steps.  Only the step interrupt changes it; code
 * outside it reads (or clears) it with interrupts masked and through
 * POS_READ, which forces a fresh read.  Not volatile itself, so that the
 * interrupt's increments stay a few instructions. */
extern FAST int32_t pos_x, pos_y;
#ifdef ZAXIS
extern XDATA int32_t pos_z;         /* build option ZAXIS: no internal RAM is left */
#endif
#define POS_READ(v) (*(volatile FAST int32_t *)&(v))
/* X and Y of one moment into pos_copy, without masking the step interrupt
 * (read until two reads agree): no step waits for it. */
extern IDATA int32_t pos_copy[2];
void stepper_snapshot(void);
void stepper_zero(void);      /* the position becomes the origin (call while still) */

/* The segment being executed, copied from its queue slot and worked on in
 * place (steps: steps left); seq stays that of the last command started. */
extern FAST segment_t st_seg;

extern volatile FLAG st_running;              /* timer running or paused mid-queue */
extern volatile FLAG st_paused;               /* stopped by a feed hold */
extern volatile FLAG st_hold;                 /* feed hold requested */
#define HOLDING st_hold
/* Request a feed hold (brake along the path and stop): the fast paths of a
 * hand-written interrupt do not test the flag, so they are left. */
#define STEPPER_HOLD() do { st_hold = 1; HAL_STEPPER_SLOW(); } while (0)
extern FAST volatile uint8_t st_port;         /* last value written to the port, without step bits */
extern FAST volatile uint8_t st_level;        /* current ramp level, as its tables' index RAMP_INDEX */
extern IDATA volatile uint16_t st_underruns;  /* queue ran dry while motion should continue */

void stepper_init(void);
void stepper_start(void);     /* begin consuming the queue (call when idle) */
void stepper_resume(void);    /* leave a feed hold */
void stepper_abort(void);     /* after HAL_TIMER_HALT: forget the current segment */
STEPPER_ISR;

#endif
