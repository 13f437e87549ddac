/* stepper.h - the step interrupt: point-by-point comparison interpolation of
 * the queued lines and arcs, the acceleration ramp, and the machine position. */
#ifndef STEPPER_H
#define STEPPER_H

#include "config.h"
#include "hal.h"

extern FAST volatile int32_t pos_x, pos_y;    /* absolute position, steps */
extern FAST volatile uint8_t st_running;      /* timer running or paused mid-queue */
extern FAST volatile uint8_t st_paused;       /* stopped by a feed hold */
extern FAST volatile uint8_t st_hold;         /* feed hold requested */
extern FAST volatile uint16_t st_seq;         /* sequence number of the current command */
extern FAST volatile uint8_t st_port;         /* last value written to the port, without step bits */
extern FAST volatile uint8_t st_level;        /* current ramp level */
extern FAST volatile uint16_t st_underruns;   /* queue ran dry while motion should continue */
extern FAST uint8_t st_accel;                 /* acceleration multiplier: steps per level x this */
extern FAST uint8_t st_shape;                 /* RAMP_TRAPEZOID or RAMP_EXPONENTIAL */

void stepper_init(void);
void stepper_start(void);     /* begin consuming the queue (call when idle) */
void stepper_resume(void);    /* leave a feed hold */
void stepper_abort(void);     /* after HAL_TIMER_HALT: forget the current segment */
STEPPER_ISR;

#endif
