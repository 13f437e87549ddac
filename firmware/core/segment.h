/* segment.h - one queued command as the step interrupt consumes it.
 * The planner fills every field outside the interrupt (all divisions and
 * square roots happen there); the interrupt copies the slot into internal RAM
 * and steps. */
#ifndef SEGMENT_H
#define SEGMENT_H

#include <stdint.h>

#define SEG_LINE    1
#define SEG_ARC_CW  2
#define SEG_ARC_CCW 3
#define SEG_PEN     4   /* set or clear the pen bit, then dwell `steps` ms */
#define SEG_DWELL   5   /* wait `steps` ms */
#define SEG_FOLLOW  6   /* build option FOLLOW: steps the main loop decides by the sensors (follow.h) */

/* Arc moves, one-hot. */
#define MV_XP 0x01
#define MV_XN 0x02
#define MV_YP 0x04
#define MV_YN 0x08
#define MV_X  (MV_XP | MV_XN)
#define MV_Y  (MV_YP | MV_YN)
#define MV_NEG (MV_XN | MV_YN)

typedef struct {
    uint8_t  kind;
    uint8_t  dirs;          /* line: BIT_X_DIR|BIT_Y_DIR; pen: BIT_PEN or 0;
                               arc in its final quadrant: the moves that head
                               towards the end (MV_*), kept by the interrupt */
    uint16_t seq;           /* sequence number of the command (0 when typed) */
    int16_t  a, b;          /* line: |dx|, |dy|; arc: start relative to the centre */
    int16_t  c, d;          /* arc: end relative to the centre */
    uint16_t steps;         /* line: exact; arc: estimate; pen/dwell: milliseconds */
    uint8_t  quadrant;      /* arc: 4 if clockwise, plus the quadrant of the start 0..3 = I..IV */
    uint8_t  crossings;     /* arc: axis crossings before the final quadrant */
    uint8_t  cruise;        /* ramp level to accelerate to */
    uint8_t  exit;          /* ramp level to leave the segment at */
    uint16_t cruise_period; /* HAL_PERIOD(machine cycles per step at the commanded feed) */
    uint16_t exit_brake;    /* hold steps of the ramp levels up to the exit level, scaled (0 for level 0) */
} segment_t;

#endif
