/* planner.h - the segment queue and the preparation of each command for the
 * step interrupt: direction bits, step counts, arc quadrants, ramp levels. */
#ifndef PLANNER_H
#define PLANNER_H

#include "config.h"
#include "hal.h"
#include "segment.h"

/* Error codes shared with the protocol (firmware/PROTOCOL.md). */
#define E_OK        0
#define E_UNKNOWN   1
#define E_CHECKSUM  2
#define E_NUMBER    3
#define E_TOOLONG   4
#define E_QUEUEFULL 5
#define E_ARGS      6
#define E_SEQUENCE  7
#define E_ARC       8
#define E_ALARM     9
#define E_BUSY      10
#define E_RANGE     11

extern XDATA segment_t queue[QUEUE_SIZE + 1];
extern FAST volatile uint8_t q_head, q_tail;   /* head: planner writes, tail: interrupt reads */

/* A ring of QUEUE_SIZE + 1 slots: one stays empty so that full and empty differ. */
#define QUEUE_SLOTS (QUEUE_SIZE + 1)
#define QUEUE_NEXT(i) ((uint8_t)((i) == QUEUE_SLOTS - 1 ? 0 : (uint8_t)((i) + 1)))

#ifdef INTERP_COMPARE
/* Per queue slot, an arc's iterations in its final quadrant, which the step
 * interrupt cannot work out (planner.c). */
extern XDATA uint16_t queue_final[QUEUE_SLOTS];
#endif

uint8_t queue_used(void);
#define QUEUE_FREE() ((uint8_t)(QUEUE_SIZE - queue_used()))
uint8_t planner_busy(void);     /* not 0 while steps run or commands are queued */

/* The numbers of the command to plan, set by the caller (the protocol) before
 * planner_line / planner_arc, in the order of the protocol's arguments:
 * dx, dy, then for an arc the centre i, j (relative to the start), all
 * -32767..32767; the feed and the exit rate in steps/s (0: the default feed,
 * resp. stop at the end) always at PLAN_FEED and PLAN_EXIT.  Arguments in
 * memory rather than as parameters: SDCC would give each function's eight
 * parameters their own bytes of the scarce direct RAM. */
#define PLAN_FEED 4
#define PLAN_EXIT 5
extern IDATA uint16_t plan_arg[6];  /* coordinates as int16_t */
extern SEQ_MEM uint16_t plan_seq;   /* sequence number of the command (0 when typed) */

/* A 32-bit work value: an arc's arithmetic in planner_arc, and the
 * protocol's number printing, which never run at once; one copy in the
 * scarce direct RAM. */
extern uint32_t plan_t;

uint8_t planner_line(void);
#ifdef ZAXIS
uint8_t planner_z(void);    /* dz at plan_arg[0], alone: Z moves, X and Y stay */
#endif
uint8_t planner_arc(uint8_t clockwise);
#ifdef FOLLOW
uint8_t planner_follow(void);   /* F: heading, lost, distance, gate at plan_arg[0..3], feed at PLAN_FEED */
#endif
uint8_t planner_pen(uint8_t down);
uint8_t planner_dwell(uint16_t ms);
void planner_flush(void);

/* The settings $0..$3 of the protocol; changed only while idle. */
#define SET_ACCEL 0     /* acceleration divisor: each ramp level is held this many times longer */
#define SET_SHAPE 1     /* RAMP_TRAPEZOID or RAMP_EXPONENTIAL */
#define SET_FEED  2     /* steps/s when a command gives none */
#define SET_PEN   3     /* settle time after a pen change, ms */
#define SETTINGS  4
#define SETTING(k) setting[k]
extern IDATA uint16_t setting[SETTINGS];

#endif
