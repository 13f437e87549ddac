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
#define QUEUE_NEXT(i) ((uint8_t)((i) + 1 == QUEUE_SLOTS ? 0 : (i) + 1))

uint8_t queue_used(void);
#define QUEUE_FREE() ((uint8_t)(QUEUE_SIZE - queue_used()))

uint8_t planner_level_for_rate(uint16_t rate);
uint8_t planner_line(int16_t dx, int16_t dy, uint16_t feed, uint16_t exit_rate, uint16_t seq);
uint8_t planner_arc(int16_t dx, int16_t dy, int16_t i, int16_t j, uint8_t clockwise,
                    uint16_t feed, uint16_t exit_rate, uint16_t seq);
uint8_t planner_pen(uint8_t down, uint16_t seq);
uint8_t planner_dwell(uint16_t ms, uint16_t seq);
void planner_flush(void);
uint16_t isqrt32(uint32_t v);

extern uint16_t default_feed;   /* steps/s when a command gives none */
extern uint16_t pen_delay_ms;   /* settle time after a pen change */

#endif
