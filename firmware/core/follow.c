/* follow.c - line following by three sensors: the steering and its stops
 * (follow.h says how it steers). */
#include "hal.h"
#include "follow.h"
#ifdef FOLLOW
#include "stepper.h"
#endif

#define HALF   (FOLLOW_DIRS / 2)
#define NONE   0xFF

/* 64 cos(15 degrees * i); sin(i) = cos(i - 6). */
static const ROM int8_t cos24[FOLLOW_DIRS] = {
    64, 62, 55, 45, 32, 17, 0, -17, -32, -45, -55, -62,
    -64, -62, -55, -45, -32, -17, 0, 17, 32, 45, 55, 62
};
#define COS(i) cos24[i]
#define SIN(i) cos24[(i) >= 6 ? (i) - 6 : (i) + FOLLOW_DIRS - 6]

/* By the black sensors (bit i: sensor i), the direction of the line from
 * the pen: one sensor's own direction, or half way between two (away from
 * the third); none with all or no sensor on black.  Sensors at 90, 210 and
 * 330 degrees are headings 6, 14 and 22. */
static const ROM uint8_t line_dir[8] = { NONE, 6, 14, 10, 22, 2, 18, NONE };

/* The steering's state.  In the FOLLOW image it lies over the segment
 * queue, which is empty while an F runs: the F is the only command queued
 * (planner.c refuses others behind it), and the interrupt has taken it out
 * of its slot before follow_service starts the steering.  The chip's 256
 * bytes of XRAM hold nothing else it could use. */
typedef struct {
    uint8_t heading;      /* where the pen is going: the line's direction as far as it is known */
    uint8_t dir;          /* the direction of this step */
    uint8_t armed;        /* the pen has been far enough from the start to come back to it */
    uint8_t behind;       /* the pen was behind the start gate at the last step */
    uint8_t stop;         /* the stop the next tick reports, 0: none */
    int16_t turn;         /* the steering's error summed, notches x steps, + left */
    int16_t judge;        /* point-by-point judgement along dir */
    uint16_t lost;        /* steps since a sensor was last on black */
    int16_t dx, dy;       /* the pen from the start, in steps */
    int16_t cx, cy;       /* the pen at the last progress check */
    int32_t along;        /* the pen from the start along the start heading, x 64 */
    int32_t across;       /* ... and across it, x 64, + left */
} steer_t;

#ifdef FOLLOW
#include "planner.h"
typedef char steer_fits_in_queue[sizeof(steer_t) <= sizeof(queue) ? 1 : -1];
#define S (*(XDATA steer_t *)queue)
#else
static steer_t S;
#endif
static XDATA uint32_t f_travelled;
XDATA follow_args_t follow_args;

void follow_start(void)
{
    uint8_t n = sizeof(steer_t);
    XDATA uint8_t *p = (XDATA uint8_t *)&S;
    do {
        *p++ = 0;
    } while (--n);
    S.heading = S.dir = follow_args.heading;
    f_travelled = 0;
}

/* A macro, not a function: the functions that use it stay leaves, whose
 * locals SDCC overlays instead of giving them direct RAM of their own. */
#define ABS16(v) ((v) < 0 ? -(v) : (v))

/* After a step: every FOLLOW_PROGRESS_STEPS steps the pen must have got at
 * least a quarter as far on, or it is going back and forth where the line
 * ends or breaks off and the line counts as lost. */
static void check_progress(void)
{
    int16_t x, y;
    if ((uint16_t)f_travelled & (FOLLOW_PROGRESS_STEPS - 1))
        return;
    x = S.dx - S.cx;
    y = S.dy - S.cy;
    if ((uint16_t)(ABS16(x) + ABS16(y)) < FOLLOW_PROGRESS_STEPS / 4)
        S.stop = FOLLOW_LOST;
    S.cx = S.dx;
    S.cy = S.dy;
}

/* After a step: the start gate is the line through the start across the
 * heading the pen set out on; crossing it forwards, within home_steps of
 * the start, once the pen has been twice that far away, is home.  Crossing
 * it backwards there is a stop too: the pen turned back somewhere and
 * would go round the line backwards, never through the gate forwards.  The
 * pen stays within 32767 steps of its start, or the line counts as lost. */
static void check_home(void)
{
    uint8_t behind = S.along < 0;
    uint16_t x = (uint16_t)ABS16(S.dx), y = (uint16_t)ABS16(S.dy);
    int32_t gate;
    if (x == 32767 || y == 32767) {
        S.stop = FOLLOW_LOST;
    } else if (!S.armed) {
        gate = follow_args.home_steps << 1;
        if (x > (uint16_t)gate || y > (uint16_t)gate)
            S.armed = 1;
    } else if (behind != S.behind) {
        /* -g <= across <= g (g: the gate's half width x 64) as one unsigned comparison */
        gate = S.across + ((int32_t)follow_args.home_steps << 6);
        if ((uint32_t)gate <= (uint32_t)follow_args.home_steps << 7)
            S.stop = behind ? FOLLOW_REVERSED : FOLLOW_HOME;
    }
    S.behind = behind;
}

/* v, in -FOLLOW_DIRS..2 FOLLOW_DIRS - 1, as a heading on the ring 0..FOLLOW_DIRS - 1. */
static uint8_t wrap(int8_t v)
{
    if (v < 0)
        v += FOLLOW_DIRS;
    if (v >= FOLLOW_DIRS)
        v -= FOLLOW_DIRS;
    return (uint8_t)v;
}

uint8_t follow_tick(uint8_t black)
{
    uint8_t target = S.heading;
    uint8_t line;
    int8_t diff = 0;
    int8_t c, s, ac, as, da, dc, d;

    if (S.stop)
        return S.stop;
    if (follow_args.max_steps && f_travelled >= follow_args.max_steps)
        return S.stop = FOLLOW_DISTANCE;
    black &= FOLLOW_SENSOR_MASK;
    if (!black) {
        if (++S.lost >= follow_args.lost_steps)
            return S.stop = FOLLOW_LOST;
    } else {
        S.lost = 0;
    }

    line = line_dir[black];
    if (line != NONE) {
        diff = (int8_t)(line - S.heading);
        if (diff > HALF)
            diff -= FOLLOW_DIRS;
        else if (diff <= -HALF)
            diff += FOLLOW_DIRS;
        if (diff == HALF)
            diff = 0;           /* the line straight behind says nothing of which way to turn */
        target = wrap((int8_t)(S.heading + (diff >= 0 ? diff >> 1 : -((-diff) >> 1))));
    }
    /* The heading turns by the steering's error summed over the steps, a
     * notch per FOLLOW_TURN: slower than the steps' own correction, so that
     * a drift is taken out sideways and only a bend of the line turns it. */
    S.turn += diff;
    if (S.turn >= FOLLOW_TURN) {
        S.heading = wrap((int8_t)(S.heading + 1));
        S.turn -= FOLLOW_TURN;
    } else if (S.turn <= -FOLLOW_TURN) {
        S.heading = wrap((int8_t)(S.heading - 1));
        S.turn += FOLLOW_TURN;
    }

    c = COS(target);
    s = SIN(target);
    ac = c < 0 ? -c : c;
    as = s < 0 ? -s : s;
    if (target != S.dir) {
        /* A new direction starts on its major axis: steering that swaps
         * between two directions every step then still moves along both. */
        S.dir = target;
        S.judge = ac >= as ? 0 : -1;
    }
    /* The step, and what it moves the pen along the start heading and
     * across it (x 64): with that heading's cosine and sine c0, s0, a step
     * along +X c0 and -s0, along +Y s0 and c0. */
    da = COS(follow_args.heading);
    dc = SIN(follow_args.heading);
    if (s == 0 || (c != 0 && S.judge >= 0)) {
        S.judge -= as;
        line = FOLLOW_STEP_XP;
        dc = -dc;
    } else {
        S.judge += ac;
        line = FOLLOW_STEP_YP;
        c = da;                  /* (c0, s0) turned a right angle: (s0, c0) after the sign above */
        da = dc;
        dc = c;
        c = s;
    }
    d = 1;
    if (c < 0) {
        line++;                  /* FOLLOW_STEP_XN, FOLLOW_STEP_YN */
        d = -1;
        da = -da;
        dc = -dc;
    }
    if (line < FOLLOW_STEP_YP)
        S.dx += d;
    else
        S.dy += d;
    S.along += da;
    S.across += dc;
    f_travelled++;
    check_progress();
    check_home();
    return line;
}

#ifdef FOLLOW
volatile XDATA uint8_t follow_next = FOLLOW_IDLE;
volatile XDATA uint8_t follow_state;

uint32_t follow_travelled(void)
{
    return f_travelled;
}

/* The F's arguments are in follow_args (planner_follow).  The sensors are
 * read only once the interrupt has taken the last step: read before, they
 * could be a main-loop pass older than that step. */
void follow_service(void)
{
    uint8_t next = follow_next;
    if (next == FOLLOW_BEGIN) {
        follow_start();
        follow_state = FOLLOW_STATE_RUNNING;
        next = FOLLOW_WAIT;
    }
    if (next != FOLLOW_WAIT)
        return;
    next = follow_tick(HAL_SENSORS());
    if (next & 0x80)
        follow_state = (uint8_t)(next - FOLLOW_HOME + FOLLOW_STATE_HOME);
    follow_next = next;
}

void follow_abort(void)
{
    if (follow_next != FOLLOW_IDLE) {
        follow_next = FOLLOW_IDLE;
        follow_state = FOLLOW_STATE_STOPPED;
    }
}
#endif
