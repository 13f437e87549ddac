/* planner.c - the segment queue, and everything about a command that needs
 * multiplication, division or square roots, done once per command outside
 * the step interrupt: absolute step counts and directions, arc quadrants and
 * axis crossings, ramp levels for the feed and exit speeds, the exact cruise
 * period, and the braking distance of the exit level. */
#include "planner.h"
#include "stepper.h"
#include "ramp.h"

XDATA segment_t queue[QUEUE_SLOTS];
FAST volatile uint8_t q_head, q_tail;

uint16_t default_feed = 2000;
uint16_t pen_delay_ms = 150;

#define FEED_MIN 15u    /* slower would overflow the 16-bit step period */

static uint16_t last_feed;
static uint16_t last_period;

uint16_t isqrt32(uint32_t v)
{
    uint32_t root = 0;
    uint32_t bit = 0x40000000UL;
    while (bit > v) {
        bit >>= 2;
    }
    while (bit) {
        if (v >= root + bit) {
            v -= root + bit;
            root = (root >> 1) + bit;
        } else {
            root >>= 1;
        }
        bit >>= 2;
    }
    return (uint16_t)root;
}

uint8_t planner_level_for_rate(uint16_t rate)
{
    RAMP_ROM uint16_t *rates = ramp_rate[st_shape];
    uint8_t lo = 0, hi = RAMP_LEVELS - 1, mid;
    if (rate <= rates[0]) {
        return 0;
    }
    while (lo < hi) {               /* largest level whose rate does not exceed `rate` */
        mid = (uint8_t)((lo + hi + 1) >> 1);
        if (rates[mid] <= rate) lo = mid; else hi = mid - 1;
    }
    return lo;
}

uint8_t queue_used(void)
{
    uint8_t tail = q_tail;          /* read once: the step interrupt moves it */
    return (uint8_t)(q_head >= tail ? q_head - tail : q_head + QUEUE_SLOTS - tail);
}

void planner_flush(void)
{
    q_tail = q_head;
}

static XDATA segment_t *next_slot(void)
{
    return &queue[q_head];
}

/* Ramp fields shared by lines and arcs. */
static void plan_speeds(XDATA segment_t *s, uint16_t feed, uint16_t exit_rate)
{
    uint16_t top = ramp_rate[st_shape][RAMP_LEVELS - 1];
    if (feed == 0) feed = default_feed;
    if (feed < FEED_MIN) feed = FEED_MIN;
    if (feed > top) feed = top;
    if (exit_rate > feed) exit_rate = feed;
    if (feed != last_feed) {
        last_feed = feed;
        last_period = (uint16_t)(CYCLES_PER_S / feed);
    }
    s->cruise = planner_level_for_rate(feed);
    s->cruise_period = last_period;
    s->exit = planner_level_for_rate(exit_rate);
    s->exit_brake = (uint16_t)(ramp_prefix[st_shape][s->exit] * st_accel);
}

uint8_t planner_line(int16_t dx, int16_t dy, uint16_t feed, uint16_t exit_rate, uint16_t seq)
{
    XDATA segment_t *s;
    uint8_t dirs = 0;
    if (dx == 0 && dy == 0) {
        return E_OK;                /* nothing to move */
    }
    if (QUEUE_FREE() == 0) {
        return E_QUEUEFULL;
    }
    s = next_slot();
    if (dx < 0) { dx = -dx; dirs |= BIT_X_DIR; }
    if (dy < 0) { dy = -dy; dirs |= BIT_Y_DIR; }
    s->kind = SEG_LINE;
    s->dirs = dirs;
    s->seq = seq;
    s->a = dx;
    s->b = dy;
    s->steps = (uint16_t)dx + (uint16_t)dy;
    plan_speeds(s, feed, exit_rate);
    q_head = QUEUE_NEXT(q_head);
    return E_OK;
}

/* Quadrant 0..3 (I..IV) of a point relative to the centre.  A point on an
 * axis belongs to the quadrant the arc is about to sweep through, so the
 * point where an arc crosses an axis already counts as the next quadrant.
 * The centre itself has no quadrant: 4. */
static uint8_t arc_quadrant(int16_t x, int16_t y, uint8_t cw)
{
    if (cw) {
        if (x >= 0 && y > 0) return 0;
        if (x < 0 && y >= 0) return 1;
        if (x <= 0 && y < 0) return 2;
        if (x > 0) return 3;
    } else {
        if (x > 0 && y >= 0) return 0;
        if (x <= 0 && y > 0) return 1;
        if (x < 0 && y <= 0) return 2;
        if (y < 0) return 3;
    }
    return 4;
}

/* How many quadrants the sweep advanced going from quadrant a to quadrant b. */
#define ARC_ADVANCE(a, b, cw) ((uint8_t)((cw) ? ((a) - (b)) : ((b) - (a))) & 3)

/* Steps of the staircase along one quadrant from half-axis k (+X, +Y, -X, -Y)
 * to the point (x, y), on a circle of radius r: it moves monotonically. */
static uint16_t steps_from_axis(uint8_t k, int16_t r, int16_t x, int16_t y)
{
    int16_t ax = (k == 0) ? r : (k == 2) ? -r : 0;
    int16_t ay = (k == 1) ? r : (k == 3) ? -r : 0;
    return (uint16_t)((ax > x ? ax - x : x - ax) + (ay > y ? ay - y : y - ay));
}

static int32_t sq(int16_t v)
{
    return (int32_t)v * v;
}

uint8_t planner_arc(int16_t dx, int16_t dy, int16_t i, int16_t j, uint8_t clockwise,
                    uint16_t feed, uint16_t exit_rate, uint16_t seq)
{
    XDATA segment_t *s;
    int16_t xs = -i, ys = -j, xe, ye;      /* start and end relative to the centre */
    int32_t t;
    uint16_t r;
    uint8_t qs, qe, cross;
    uint32_t steps;

    t = (int32_t)dx - i;
    if (t > 32767 || t < -32767) return E_RANGE;
    xe = (int16_t)t;
    t = (int32_t)dy - j;
    if (t > 32767 || t < -32767) return E_RANGE;
    ye = (int16_t)t;
    t = sq(xs) + sq(ys);                    /* R^2, at most 2 * 32767^2 */
    r = isqrt32((uint32_t)t);
    if (r == 0) return E_ARC;               /* the centre is the start point */
    if (r > 32767) return E_RANGE;
    t -= sq(xe) + sq(ye);
    if (t < 0) t = -t;
    if ((uint32_t)t > 2UL * r + 1) return E_ARC;   /* end more than a step off the circle */
    if (QUEUE_FREE() == 0) return E_QUEUEFULL;

    clockwise = clockwise ? 1 : 0;
    qs = arc_quadrant(xs, ys, clockwise);
    qe = arc_quadrant(xe, ye, clockwise);
    cross = ARC_ADVANCE(qs, qe, clockwise);
    if (cross == 0) {
        /* Same quadrant: ahead of the start, or all the way round. */
        t = (int32_t)xs * ye - (int32_t)ys * xe;
        if (clockwise) t = -t;
        if (t < 0 || (t == 0 && xs == xe && ys == ye)) cross = 4;
    }
    if (cross == 0) {
        steps = (uint16_t)((xs > xe ? xs - xe : xe - xs) + (ys > ye ? ys - ye : ye - ys));
    } else {
        /* Quadrant q runs from half-axis q to q+1 counter-clockwise, q+1 to q clockwise. */
        steps = steps_from_axis(clockwise ? qs : (qs + 1) & 3, (int16_t)r, xs, ys)
              + (uint32_t)(cross - 1) * 2u * r
              + steps_from_axis(clockwise ? (qe + 1) & 3 : qe, (int16_t)r, xe, ye);
    }
    s = next_slot();
    s->kind = clockwise ? SEG_ARC_CW : SEG_ARC_CCW;
    s->seq = seq;
    s->a = xs;
    s->b = ys;
    s->c = xe;
    s->d = ye;
    s->quadrant = qs;
    s->crossings = cross;
    s->steps = steps > 65535UL ? 65535u : (uint16_t)steps;
    plan_speeds(s, feed, exit_rate);
    q_head = QUEUE_NEXT(q_head);
    return E_OK;
}

static uint8_t plan_wait(uint8_t kind, uint8_t pen_bit, uint16_t ms, uint16_t seq)
{
    XDATA segment_t *s;
    if (QUEUE_FREE() == 0) {
        return E_QUEUEFULL;
    }
    s = next_slot();
    s->kind = kind;
    s->dirs = pen_bit;
    s->seq = seq;
    s->steps = ms;
    s->cruise = 0;
    s->exit = 0;
    s->cruise_period = DWELL_PERIOD;
    s->exit_brake = 0;
    q_head = QUEUE_NEXT(q_head);
    return E_OK;
}

uint8_t planner_pen(uint8_t down, uint16_t seq)
{
    return plan_wait(SEG_PEN, down ? BIT_PEN : 0, pen_delay_ms ? pen_delay_ms : 1, seq);
}

uint8_t planner_dwell(uint16_t ms, uint16_t seq)
{
    if (ms == 0) {
        return E_OK;
    }
    return plan_wait(SEG_DWELL, 0, ms, seq);
}
