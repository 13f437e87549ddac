/* follow.c - line following by three sensors: the steering and its stops
 * (follow.h says how it steers). */
#include "hal.h"
#include "follow.h"

#define HALF   (FOLLOW_DIRS / 2)
#define NONE   0xFF

/* 64 cos(15 degrees * i); sin(i) = cos(i - 6). */
static const ROM int8_t cos24[FOLLOW_DIRS] = {
    64, 62, 55, 45, 32, 17, 0, -17, -32, -45, -55, -62,
    -64, -62, -55, -45, -32, -17, 0, 17, 32, 45, 55, 62
};
#define COS(i) cos24[i]
#define SIN(i) cos24[((i) + FOLLOW_DIRS - 6) % FOLLOW_DIRS]

/* By the black sensors (bit i: sensor i), the direction of the line from
 * the pen: one sensor's own direction, or half way between two (away from
 * the third); none with all or no sensor on black.  Sensors at 90, 210 and
 * 330 degrees are headings 6, 14 and 22. */
static const ROM uint8_t line_dir[8] = { NONE, 6, 14, 10, 22, 2, 18, NONE };

static XDATA follow_args_t f_args;
static XDATA uint8_t f_heading;      /* where the pen is going: the line's direction as far as it is known */
static XDATA uint8_t f_dir;          /* the direction of this step */
static XDATA int16_t f_turn;         /* the steering's error summed, notches x steps, + left */
static XDATA int16_t f_judge;        /* point-by-point judgement along f_dir */
static XDATA uint16_t f_lost;        /* steps since a sensor was last on black */
static XDATA uint32_t f_travelled;
static XDATA int32_t f_dx, f_dy;     /* the pen from the start, in steps */
static XDATA int32_t f_along;        /* ... along the start heading (x 64), at the last step */
static XDATA uint8_t f_armed;        /* the pen has been far enough from the start to come back to it */
static XDATA uint8_t f_stop;         /* the stop the next tick reports, 0: none */
static XDATA int32_t f_cx, f_cy;     /* the pen at the last progress check */

void follow_start(const follow_args_t *args)
{
    f_args = *args;
    f_heading = f_dir = (uint8_t)(args->heading % FOLLOW_DIRS);
    f_turn = 0;
    f_judge = 0;
    f_lost = 0;
    f_travelled = 0;
    f_dx = f_dy = 0;
    f_along = 0;
    f_armed = 0;
    f_stop = 0;
    f_cx = f_cy = 0;
}

static int32_t abs32(int32_t v) { return v < 0 ? -v : v; }

/* After a step: every FOLLOW_PROGRESS_STEPS steps the pen must have got at
 * least a quarter as far on, or it is going back and forth where the line
 * ends or breaks off and the line counts as lost. */
static void check_progress(void)
{
    if (f_travelled % FOLLOW_PROGRESS_STEPS)
        return;
    if (abs32(f_dx - f_cx) + abs32(f_dy - f_cy) < FOLLOW_PROGRESS_STEPS / 4)
        f_stop = FOLLOW_LOST;
    f_cx = f_dx;
    f_cy = f_dy;
}

/* After a step: the start gate is the line through the start across the
 * heading the pen set out on; crossing it forwards, within home_steps of
 * the start, once the pen has been twice that far away, is home. */
static void check_home(void)
{
    uint8_t h0 = (uint8_t)(f_args.heading % FOLLOW_DIRS);
    int32_t gate = (int32_t)f_args.home_steps;
    int32_t along = f_dx * COS(h0) + f_dy * SIN(h0);
    int32_t across = f_dy * COS(h0) - f_dx * SIN(h0);
    if (!f_armed) {
        if (abs32(f_dx) > 2 * gate || abs32(f_dy) > 2 * gate)
            f_armed = 1;
    } else if (f_along < 0 && along >= 0 && abs32(across) <= gate * 64) {
        f_stop = FOLLOW_HOME;
    }
    f_along = along;
}

uint8_t follow_tick(uint8_t black)
{
    uint8_t target = f_heading;
    uint8_t line, step;
    int8_t diff = 0;
    int8_t c, s;

    if (f_stop)
        return f_stop;
    if (f_args.max_steps && f_travelled >= f_args.max_steps)
        return f_stop = FOLLOW_DISTANCE;
    black &= FOLLOW_SENSOR_MASK;
    if (!black) {
        if (++f_lost >= f_args.lost_steps)
            return f_stop = FOLLOW_LOST;
    } else {
        f_lost = 0;
    }

    line = line_dir[black];
    if (line != NONE) {
        diff = (int8_t)((line + FOLLOW_DIRS - f_heading) % FOLLOW_DIRS);
        if (diff > HALF)
            diff -= FOLLOW_DIRS;
        if (diff == HALF)
            diff = 0;           /* the line straight behind says nothing of which way to turn */
        target = (uint8_t)((f_heading + FOLLOW_DIRS + diff / 2) % FOLLOW_DIRS);
    }
    /* The heading turns by the steering's error summed over the steps, a
     * notch per FOLLOW_TURN: slower than the steps' own correction, so that
     * a drift is taken out sideways and only a bend of the line turns it. */
    f_turn += diff;
    if (f_turn >= FOLLOW_TURN) {
        f_heading = (uint8_t)((f_heading + 1) % FOLLOW_DIRS);
        f_turn -= FOLLOW_TURN;
    } else if (f_turn <= -FOLLOW_TURN) {
        f_heading = (uint8_t)((f_heading + FOLLOW_DIRS - 1) % FOLLOW_DIRS);
        f_turn += FOLLOW_TURN;
    }

    c = COS(target);
    s = SIN(target);
    if (target != f_dir) {
        /* A new direction starts on its major axis: steering that swaps
         * between two directions every step then still moves along both. */
        f_dir = target;
        f_judge = (c < 0 ? -c : c) >= (s < 0 ? -s : s) ? 0 : -1;
    }
    if (s == 0 || (c != 0 && f_judge >= 0)) {
        step = c > 0 ? FOLLOW_STEP_XP : FOLLOW_STEP_XN;
        f_dx += c > 0 ? 1 : -1;
        f_judge -= s < 0 ? -s : s;
    } else {
        step = s > 0 ? FOLLOW_STEP_YP : FOLLOW_STEP_YN;
        f_dy += s > 0 ? 1 : -1;
        f_judge += c < 0 ? -c : c;
    }
    f_travelled++;
    check_progress();
    check_home();
    return step;
}
