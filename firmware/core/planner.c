/* planner.c - the segment queue, and everything about a command that needs
 * multiplication, division or square roots, done once per command outside
 * the step interrupt: absolute step counts and directions, arc quadrants and
 * axis crossings, ramp levels for the feed and exit speeds, the exact cruise
 * period, and the braking distance of the exit level. */
#include "planner.h"
#include "stepper.h"
#include "ramp.h"

XDATA segment_t queue[QUEUE_SIZE];
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

void planner_flush(void)
{
    q_tail = q_head;
}

static XDATA segment_t *next_slot(void)
{
    return &queue[q_head & (QUEUE_SIZE - 1)];
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
    q_head++;
    return E_OK;
}

/* Quadrant 0..3 (I..IV) of a point relative to the centre.  A point on an
 * axis belongs to the quadrant the arc is about to sweep through. */
static uint8_t quadrant_of(int16_t x, int16_t y, uint8_t cw)
{
    if (cw) {
        if (x >= 0 && y > 0) return 0;
        if (x < 0 && y >= 0) return 1;
        if (x <= 0 && y < 0) return 2;
        return 3;
    }
    if (x > 0 && y >= 0) return 0;
    if (x <= 0 && y > 0) return 1;
    if (x < 0 && y <= 0) return 2;
    return 3;
}

/* Where the arc enters (first = 1) or leaves (first = 0) quadrant q, on a circle of radius r. */
static void quadrant_end(uint8_t q, uint8_t cw, uint8_t first, int16_t r, int16_t *x, int16_t *y)
{
    /* Axis points in counter-clockwise order: +X, +Y, -X, -Y. Quadrant q spans q..q+1. */
    uint8_t k = (uint8_t)(q + ((cw ^ first) ? 0 : 1)) & 3;
    *x = (k == 0) ? r : (k == 2) ? -r : 0;
    *y = (k == 1) ? r : (k == 3) ? -r : 0;
}

static uint16_t manhattan(int16_t x0, int16_t y0, int16_t x1, int16_t y1)
{
    return (uint16_t)((x0 > x1 ? x0 - x1 : x1 - x0) + (y0 > y1 ? y0 - y1 : y1 - y0));
}

uint8_t planner_arc(int16_t dx, int16_t dy, int16_t i, int16_t j, uint8_t clockwise,
                    uint16_t feed, uint16_t exit_rate, uint16_t seq)
{
    XDATA segment_t *s;
    int32_t xs = -(int32_t)i, ys = -(int32_t)j;
    int32_t xe = (int32_t)dx - i, ye = (int32_t)dy - j;
    uint32_t r2, e2, diff;
    uint16_t r;
    uint8_t qs, qe, cross;
    int32_t turn;
    uint32_t steps;
    int16_t ax, ay, bx, by;

    if (xe > 32767 || xe < -32767 || ye > 32767 || ye < -32767 ||
        xs > 32767 || xs < -32767 || ys > 32767 || ys < -32767) {
        return E_RANGE;
    }
    r2 = (uint32_t)(xs * xs) + (uint32_t)(ys * ys);
    e2 = (uint32_t)(xe * xe) + (uint32_t)(ye * ye);
    r = isqrt32(r2);
    if (r == 0) {
        return E_ARC;               /* the centre is the start point */
    }
    if (r > 32767) {
        return E_RANGE;
    }
    diff = e2 > r2 ? e2 - r2 : r2 - e2;
    if (diff > 2UL * r + 1) {
        return E_ARC;               /* end more than a step off the circle */
    }
    if (QUEUE_FREE() == 0) {
        return E_QUEUEFULL;
    }
    clockwise = clockwise ? 1 : 0;
    qs = quadrant_of((int16_t)xs, (int16_t)ys, clockwise);
    qe = quadrant_of((int16_t)xe, (int16_t)ye, clockwise);
    cross = (uint8_t)(clockwise ? (qs - qe) : (qe - qs)) & 3;
    if (cross == 0) {
        /* Same quadrant: ahead of the start, or all the way round. */
        turn = xs * ye - ys * xe;
        if (clockwise) turn = -turn;
        if (turn < 0 || (turn == 0 && xs == xe && ys == ye)) {
            cross = 4;
        }
    }
    if (cross == 0) {
        steps = manhattan((int16_t)xs, (int16_t)ys, (int16_t)xe, (int16_t)ye);
    } else {
        quadrant_end(qs, clockwise, 0, (int16_t)r, &ax, &ay);
        quadrant_end(qe, clockwise, 1, (int16_t)r, &bx, &by);
        steps = (uint32_t)manhattan((int16_t)xs, (int16_t)ys, ax, ay)
              + (uint32_t)(cross - 1) * 2u * r
              + manhattan(bx, by, (int16_t)xe, (int16_t)ye);
    }
    s = next_slot();
    s->kind = clockwise ? SEG_ARC_CW : SEG_ARC_CCW;
    s->seq = seq;
    s->a = (int16_t)xs;
    s->b = (int16_t)ys;
    s->c = (int16_t)xe;
    s->d = (int16_t)ye;
    s->quadrant = qs;
    s->crossings = cross;
    s->steps = steps > 65535UL ? 65535u : (uint16_t)(steps ? steps : 1);
    plan_speeds(s, feed, exit_rate);
    q_head++;
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
    q_head++;
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
