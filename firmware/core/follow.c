/* follow.c - line following by three sensors: the steering and its stops
 * (follow.h says how it steers). */
#include "hal.h"
#include "follow.h"
#ifdef FOLLOW
#include "stepper.h"
#endif

#define HALF   (FOLLOW_DIRS / 2)
#define NONE   0xFF

/* 64 sin(15 degrees * i), a quarter turn more than round: cos(i) = sin(i + 6). */
static const ROM int8_t sin30[FOLLOW_DIRS + 6] = {
    0, 17, 32, 45, 55, 62, 64, 62, 55, 45, 32, 17,
    0, -17, -32, -45, -55, -62, -64, -62, -55, -45, -32, -17,
    0, 17, 32, 45, 55, 62
};
#define SIN(i) sin30[i]
#define COS(i) sin30[(uint8_t)((i) + 6)]

/* By the black sensors (bit i: sensor i), the direction of the line from
 * the pen: one sensor's own direction, or half way between two (away from
 * the third); none with all or no sensor on black.  Sensors at 90, 210 and
 * 330 degrees are headings 6, 14 and 22. */
static const ROM uint8_t line_dir[8] = { NONE, 6, 14, 10, 22, 2, 18, NONE };

/* The corner search.  Where the line turns sharper than the steering
 * can, the pen overshoots and the line falls behind it (CORNER_TRIGGER).
 * The pen then goes back to the last point where all three sensors read
 * black, the corner, and sets out from it a right angle to the left of
 * the heading it had there; a probe that turns back the way the pen came,
 * or loses the line behind it again, within CORNER_PROBE steps is taken
 * back to the corner and the right tried; after the right, the line is
 * lost.  The way the pen came is its heading CORNER_AGE to twice that
 * many steps before the search, not the heading at the corner: at the end
 * of a line wider than the sensor ring, the steering has already turned
 * the pen part way round the line's rounded end before the line falls
 * behind, and a probe back down the line would look like a way on. */
#define CORNER_TRIGGER 10   /* notches, 150 degrees: the line this far off the heading is behind the pen */
#define CORNER_SETTLE  10   /* steps off the all-black before the line behind starts a search */
#define CORNER_PROBE   2    /* heading samples a probe is watched for turning back: 513 to 1024 steps */
#define CORNER_TURN    6    /* a probe's heading from the corner's: a right angle */
#define CORNER_BACK    3    /* notches: a heading this near the way back has turned back */
#define CORNER_AGE     512  /* steps between samples of the heading, a power of two */

#define SEARCH_NONE  0
#define SEARCH_BACK  1      /* going back to the corner */
#define SEARCH_PROBE 2      /* steering from the corner along a probe's heading */

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
    int8_t turn;          /* the steering's error summed, notches x steps, + left (within +-105) */
    int8_t judge;         /* point-by-point judgement along dir (within +-64) */
    uint16_t lost;        /* steps since a sensor was last on black */
    int16_t d[2];         /* the pen from the start, in steps: X, Y */
    int16_t c[2];         /* the pen at the last progress check */
    int32_t along;        /* the pen from the start along the start heading, x 64 */
    int32_t across;       /* ... and across it, x 64, + left */
    uint32_t gate;        /* the start gate's half width, x 64: worked out once, so that check_home
                             calls nothing and stays a leaf, its locals overlaid (direct RAM is all but used) */
    uint8_t search;       /* SEARCH_*: where the corner search is */
    uint8_t tries;        /* the corner's probes so far */
    uint8_t corner_heading; /* the heading at the corner: the last point all three sensors read black */
    uint8_t since;        /* steps since all three read black, up to CORNER_SETTLE */
    uint8_t probe;        /* the probe's heading samples left */
    int16_t o[2];         /* the corner, from the start in steps */
    uint8_t came[2];      /* the heading sampled 0 to CORNER_AGE steps ago, and the sample before:
                             the way the pen came (sampled while no search runs) */
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
    /* came[1] takes came[0] at the first tick (f_travelled 0 is a sample) */
    S.heading = S.dir = S.corner_heading = S.came[0] = follow_args.heading;
    S.gate = HAL_MUL16U(follow_args.home_steps, 64);
    f_travelled = 0;
}

/* A macro, not a function: the functions that use it stay leaves, whose
 * locals SDCC overlays instead of giving them direct RAM of their own. */
#define ABS16(v) ((v) < 0 ? -(v) : (v))

/* Four bytes from to to: a pen position (int16_t[2]). */
static void copy4(XDATA uint8_t *to, XDATA uint8_t *from)
{
    uint8_t n = 4;
    do {
        *to++ = *from++;
    } while (--n);
}

/* After a step: every FOLLOW_PROGRESS_STEPS steps the pen must have got at
 * least a quarter as far on, or it is going back and forth where the line
 * ends or breaks off and the line counts as lost. */
static void check_progress(void)
{
    int16_t x, y;
    if ((uint16_t)f_travelled & (FOLLOW_PROGRESS_STEPS - 1))
        return;
    x = S.d[0] - S.c[0];
    y = S.d[1] - S.c[1];
    if ((uint16_t)(ABS16(x) + ABS16(y)) < FOLLOW_PROGRESS_STEPS / 4)
        S.stop = FOLLOW_LOST;
    copy4((XDATA uint8_t *)S.c, (XDATA uint8_t *)S.d);
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
    int16_t sx = S.d[0], sy = S.d[1];  /* read once: ABS16 of S.d[i] would read it twice */
    uint16_t x = (uint16_t)ABS16(sx), y = (uint16_t)ABS16(sy);
    if (y > x)
        x = y;                   /* the pen's reach from the start along X or Y */
    if (x == 32767) {
        S.stop = FOLLOW_LOST;
    } else if (!S.armed) {
        if (x > follow_args.home_steps << 1)
            S.armed = 1;
    } else if (behind != S.behind) {
        /* -g <= across <= g (g: the gate's half width x 64) as one unsigned comparison */
        if ((uint32_t)(S.across + S.gate) <= S.gate << 1)
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

/* Go back to the corner (again), or give up after the second probe.
 * (tries counts the probes of this corner: only a probe's end that finds
 * the line again, back to SEARCH_NONE, clears it.) */
static uint8_t search_begin(void)
{
    if (S.tries >= 2)
        return S.stop = FOLLOW_LOST;
    S.search = SEARCH_BACK;
    return 0;
}

/* The axis heading of the next step back to the corner, a staircase; at
 * the corner the next probe's heading is set and the answer is NONE. */
static uint8_t back_heading(void)
{
    int16_t x = S.o[0] - S.d[0], y = S.o[1] - S.d[1];
    int8_t h = 0;
    if (x || y) {
        if ((uint16_t)ABS16(x) >= (uint16_t)ABS16(y)) {
            if (x < 0)
                h = HALF;
        } else {
            h = FOLLOW_DIRS / 4;
            if (y < 0)
                h = 3 * FOLLOW_DIRS / 4;
        }
        return (uint8_t)h;
    }
    h = (int8_t)(S.corner_heading + CORNER_TURN);
    if (S.tries++)
        h -= 2 * CORNER_TURN;
    S.heading = S.dir = wrap(h);
    S.turn = 0;
    S.judge = 0;
    S.search = SEARCH_PROBE;
    S.probe = CORNER_PROBE;
    return NONE;
}

/* *p, a little-endian number of n bytes, plus v: one loop for the
 * steering's 16- and 32-bit sums, which SDCC would spell out each time
 * (on the board, hal/mcs51/add8.asm). */
#ifdef HAL_ADD8
#define add_to HAL_ADD8
#else
static void add_to(XDATA uint8_t *p, int8_t v, uint8_t n)
{
    uint8_t ext = v < 0 ? 0xFF : 0;
    uint16_t sum = (uint8_t)v;
    do {
        sum += *p;
        *p++ = (uint8_t)sum;
        sum = (sum >> 8) + ext;
    } while (--n);
}
#endif

/* The step along direction target, by point-by-point comparison: a new
 * direction starts on its major axis, so that steering that swaps between
 * two directions every step still moves along both. */
static const ROM uint8_t step_angle[4] = { 0, HALF, FOLLOW_DIRS / 4, 3 * FOLLOW_DIRS / 4 };

static uint8_t step_towards(uint8_t target)
{
    int8_t c = COS(target), s = SIN(target);
    uint8_t ac = (uint8_t)ABS16(c), as = (uint8_t)ABS16(s);
    uint8_t step, a;
    if (target != S.dir) {
        S.dir = target;
        S.judge = (int8_t)-(ac < as);
    }
    if (s == 0 || (c != 0 && S.judge >= 0)) {
        S.judge -= as;
        step = FOLLOW_STEP_XP;
    } else {
        S.judge += ac;
        step = FOLLOW_STEP_YP;
        c = s;
    }
    if (c < 0)
        step++;                  /* FOLLOW_STEP_XN, FOLLOW_STEP_YN */
    /* A step in direction a (+X, -X, +Y, -Y: 0, 12, 6, 18 notches) moves
     * the pen cos(a - h) along the start heading h and sin(a - h) across it. */
    add_to((XDATA uint8_t *)&S.d[step >> 1], (int8_t)((step & 1) ? -1 : 1), 2);
    a = wrap((int8_t)(step_angle[step] - follow_args.heading));
    add_to((XDATA uint8_t *)&S.along, COS(a), 4);
    add_to((XDATA uint8_t *)&S.across, SIN(a), 4);
    return step;
}

uint8_t follow_tick(uint8_t black)
{
    uint8_t target;
    uint8_t line;
    uint8_t far;
    int8_t diff, notch;

    if (S.stop)
        return S.stop;
    /* A probe heading back the way the pen came is on the leg it came on
     * (or round the end of the line): back to the corner for the next. */
    if (S.search == SEARCH_PROBE &&
        wrap((int8_t)(S.heading - S.came[1] + HALF + CORNER_BACK)) <= 2 * CORNER_BACK)
        goto search;
    if (!((uint16_t)f_travelled & (CORNER_AGE - 1))) {
        if (S.search == SEARCH_PROBE && !--S.probe) {
            /* a way on: the samples start again from its heading */
            S.search = SEARCH_NONE;
            S.tries = 0;
            S.came[0] = S.heading;
        }
        if (S.search == SEARCH_NONE) {
            S.came[1] = S.came[0];
            S.came[0] = S.heading;
        }
    }
    if (S.search == SEARCH_BACK) {
back:
        target = back_heading();
        if (target != NONE)
            goto step;
    }
    target = S.heading;
    if (follow_args.max_steps && f_travelled >= follow_args.max_steps)
        return S.stop = FOLLOW_DISTANCE;
    black &= FOLLOW_SENSOR_MASK;
    if (black == FOLLOW_SENSOR_MASK) {
        S.since = 0;
        if (S.search == SEARCH_NONE) {
            copy4((XDATA uint8_t *)S.o, (XDATA uint8_t *)S.d);
            S.corner_heading = S.heading;
        }
    } else if (S.since < CORNER_SETTLE) {
        S.since++;
    }
    if (!black) {
        if (++S.lost >= follow_args.lost_steps)
            return S.stop = FOLLOW_LOST;
    } else {
        S.lost = 0;
    }

    diff = 0;                    /* set here, not at the top: not kept across the wrap() above */
    line = line_dir[black];
    if (line != NONE) {
        /* line - heading, on the ring as -HALF + 1 .. HALF */
        diff = (int8_t)(wrap((int8_t)(line - S.heading + HALF - 1)) - (HALF - 1));
        far = (uint8_t)(diff + CORNER_TRIGGER - 1) > 2 * (CORNER_TRIGGER - 1);
        if (far && S.since >= CORNER_SETTLE) {
search:
            if (search_begin())
                return FOLLOW_LOST;
            goto back;
        }
        if (diff == HALF)
            diff = 0;           /* the line straight behind says nothing of which way to turn */
        target = wrap((int8_t)(S.heading + ((int8_t)(diff + (diff < 0)) >> 1)));   /* half, towards 0 */
    }
    /* The heading turns by the steering's error summed over the steps, a
     * notch per FOLLOW_TURN: slower than the steps' own correction, so that
     * a drift is taken out sideways and only a bend of the line turns it. */
    diff += S.turn;
    notch = 0;
    if (diff >= FOLLOW_TURN) {
        notch = 1;
        diff -= FOLLOW_TURN;
    } else if (diff <= -FOLLOW_TURN) {
        notch = -1;
        diff += FOLLOW_TURN;
    }
    S.turn = diff;
    S.heading = wrap((int8_t)(S.heading + notch));

step:
    line = step_towards(target);
    add_to((XDATA uint8_t *)&f_travelled, 1, 4);
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
