/* follow.h - line following (seed 003): steering by three reflective sensors
 * around the pen, one decision per step period.
 *
 * The sensors sit on a ring round the pen, 120 degrees apart (sensor 0 at
 * +Y, 1 at 210 degrees, 2 at 330), and read black over the line.  The line
 * is wider than the ring (firmware/README.md): with the pen on the line all
 * three read black, and a sensor that reads white says the pen has drifted
 * towards that side.  Each step goes half way between the heading and the
 * direction of the black sensors (the seed's table 1: towards the line);
 * the heading turns a notch (15 degrees) towards it each time the error
 * summed over the steps reaches FOLLOW_TURN, so on a straight line
 * the pen settles with all three black and the heading along the line.
 * Steps are point-by-point comparison steps, one axis each, along the
 * direction chosen.  At a corner sharper than the steering can turn, the
 * line falls behind the pen: it goes back to the last point where all
 * three sensors read black and tries a right angle to the left, then to
 * the right (follow.c, the corner search).
 *
 * Plain C, no hardware: one call of follow_tick() per step period with the
 * sensor bits, answering the step to make.  The host build drives it from a
 * virtual sheet (plotter_bridge/sim/follow.py).
 *
 * The FOLLOW=1 image runs it as the command F (firmware/PROTOCOL.md): the
 * queued F becomes a segment of kind SEG_FOLLOW, and while it runs the main
 * loop (follow_service) keeps one decided step in the mailbox follow_next,
 * which the step interrupt takes at each period.  follow_tick's arithmetic
 * (32-bit products) stays out of the interrupt, which calls no function. */
#ifndef FOLLOW_H
#define FOLLOW_H

#include <stdint.h>

#define FOLLOW_DIRS        24   /* headings, 15 degrees apart; 0 is +X, counter-clockwise */
#define FOLLOW_PROGRESS_STEPS 2048 /* the pen must get a quarter of this far on in this many steps */
#define FOLLOW_TURN        96   /* the steering's error, notches x steps, that turns the heading a notch */
#define FOLLOW_KEY_PASSES  200  /* main-loop passes the follow key must be held (protocol.c follow_key) */
#define FOLLOW_KEY_LOST    400  /* the key's lost steps and gate before any F: 5 mm and 3.5 mm at 80 steps/mm */
#define FOLLOW_KEY_GATE    280
#define FOLLOW_MAX_GATE    16383 /* steps: the home gate's largest half width (<< 1 stays within 16 bits) */

/* follow_tick's answer: a step (axis and sign) or why the mode stopped. */
#define FOLLOW_STEP_XP     0
#define FOLLOW_STEP_XN     1
#define FOLLOW_STEP_YP     2
#define FOLLOW_STEP_YN     3
#define FOLLOW_HOME        0x80 /* back through the start, across the heading it set out on */
#define FOLLOW_LOST        0x81 /* no sensor on black for the lost distance, or no way on */
#define FOLLOW_DISTANCE    0x82 /* followed the distance asked for */
#define FOLLOW_REVERSED    0x84 /* back through the start against the way it set out: it turned back along the
                                   line (at a corner too sharp), and would go round backwards for ever */

#define FOLLOW_SENSOR_MASK 0x07 /* bit i: sensor i reads black */

typedef struct {
    uint8_t heading;          /* 0 .. FOLLOW_DIRS-1: the direction to set out in */
    uint16_t lost_steps;      /* steps with no sensor on black before FOLLOW_LOST */
    uint16_t max_steps;       /* steps before FOLLOW_DISTANCE; 0: no limit */
    uint16_t home_steps;      /* 0..FOLLOW_MAX_GATE: the start gate's half width, and how far the pen must go from the start
                                 before crossing the gate counts as home */
} follow_args_t;

extern XDATA follow_args_t follow_args;   /* the next follow_start's arguments */
void follow_start(void);
uint8_t follow_tick(uint8_t black);

#ifdef FOLLOW
/* follow_next, the mailbox between the main loop and the step interrupt:
 * a step (FOLLOW_STEP_*) or stop the interrupt takes, or one of these. */
#define FOLLOW_QUEUED      0xFC /* an F is queued: nothing may queue behind it */
#define FOLLOW_IDLE        0xFD /* no F queued or running */
#define FOLLOW_BEGIN       0xFE /* the interrupt has loaded an F: the main loop starts it */
#define FOLLOW_WAIT        0xFF /* the interrupt took the last answer: the main loop decides the next */
extern volatile XDATA uint8_t follow_next;

/* The mode's state in the status report (F field): what the last F did. */
#define FOLLOW_STATE_NONE     0 /* no F since reset */
#define FOLLOW_STATE_RUNNING  1
#define FOLLOW_STATE_HOME     2 /* a stop: its code (FOLLOW_HOME...) - FOLLOW_HOME + 2 */
#define FOLLOW_STATE_LOST     3
#define FOLLOW_STATE_DISTANCE 4
#define FOLLOW_STATE_STOPPED  5 /* ended by a reset or an alarm (the A field says which) */
#define FOLLOW_STATE_REVERSED 6 /* FOLLOW_REVERSED (0x83 would be state 5) */
extern volatile XDATA uint8_t follow_state;

uint32_t follow_travelled(void);     /* steps followed by the current or last F */
void follow_service(void);           /* main loop: answer the interrupt's next step by the sensors */
void follow_abort(void);             /* the F, if one runs, ended by a reset or an alarm */
#endif

#endif
