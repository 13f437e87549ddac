/* planner.c - the segment queue, and everything about a command that needs
 * multiplication, division or square roots, done once per command outside
 * the step interrupt: absolute step counts and directions, arc quadrants and
 * axis crossings, ramp levels for the feed and exit speeds, the exact cruise
 * period, and the braking distance of the exit level.
 *
 * A command is prepared in `plan` and copied into the queue only when it is
 * complete: the step interrupt never sees a half-written slot.  Work values
 * live in `plan` and a few globals, and the helpers are leaf functions:
 * SDCC overlays the locals of functions that call no others, everything
 * else would take fixed bytes of direct RAM. */
#include "planner.h"
#include "stepper.h"
#include "ramp.h"
#ifdef FOLLOW
#include "follow.h"
#endif

XDATA segment_t queue[QUEUE_SLOTS];
#ifdef INTERP_COMPARE
XDATA uint16_t queue_final[QUEUE_SLOTS];
#endif
FAST volatile uint8_t q_head, q_tail;
IDATA uint16_t plan_arg[6];
SEQ_MEM uint16_t plan_seq;

IDATA uint16_t setting[SETTINGS] = {1, RAMP_TRAPEZOID, 2000, 150};

/* The slowest feed, steps/s (slower ones run at it): slower would overflow
 * the 16-bit step period.  At 6 clocks per cycle (CPU_6T) a turn of the
 * timer lasts 35.6 ms instead of 71.1, so the floor doubles. */
#ifdef CPU_6T
#define FEED_MIN 29u
#else
#define FEED_MIN 15u
#endif

static IDATA segment_t plan;
uint32_t plan_t;
#define arc_t plan_t            /* arc: R^2, then work values */
static uint16_t arc_r;          /* arc: radius, rounded down */
static FLAG arc_cw;             /* arc: clockwise */

/* arc_r = the square root of arc_t, rounded down (arc_t < 2^31). */
static void arc_sqrt(void)
{
    uint16_t bit = 0x8000;
    arc_r = 0;
    do {
        arc_r |= bit;
        if (HAL_MUL16U(arc_r, arc_r) > arc_t) {
            arc_r ^= bit;
        }
        bit >>= 1;
    } while (bit);
}

uint8_t queue_used(void)
{
    uint8_t n = (uint8_t)(q_head - q_tail);    /* q_tail read once: the step interrupt moves it */
    if (n >= QUEUE_SLOTS) n += QUEUE_SLOTS;     /* wrapped below 0 */
    return n;
}

uint8_t planner_busy(void)
{
    if (st_running) return 1;
    return queue_used();
}

void planner_flush(void)
{
    q_tail = q_head;
}

/* Append `plan` to the queue. */
static uint8_t commit(void)
{
    XDATA uint8_t *dst;
    IDATA uint8_t *src;
    uint8_t n, next = (uint8_t)(q_head + 1);
#ifdef FOLLOW
    /* Nothing queues behind an F: the steering keeps its state in the queue (follow.c). */
    if (follow_next != FOLLOW_IDLE) return E_BUSY;
#endif
    if (next == QUEUE_SLOTS) next = 0;      /* QUEUE_NEXT, in 8 bits */
    if (next == q_tail) {
        return E_QUEUEFULL;
    }
    plan.seq = plan_seq;
    dst = (XDATA uint8_t *)&queue[q_head];
    src = (IDATA uint8_t *)&plan;
    n = sizeof(segment_t);
    do {
        *dst++ = *src++;
    } while (--n);
    q_head = next;
    return E_OK;
}

/* The step period at rate f, CYCLES_PER_S / f machine cycles rounded, in
 * the timer's form (HAL_PERIOD), for f in FEED_MIN..32767.  A long division
 * by shift and subtract, the quotient shifting in where the dividend shifts
 * out: it needs no library division, and with CYCLES_PER_S < FEED_MIN * 2^16
 * the quotient fits 16 bits. */
#if CYCLES_PER_S >= FEED_MIN * 65536UL || LINE_TOP > 32767 || ARC_TOP > LINE_TOP
#error period_of: the quotient or the feed outgrows 16 bits
#endif
static uint16_t period_of(uint16_t f)
{
    uint16_t hi = (uint16_t)(CYCLES_PER_S >> 16);
    uint16_t lo = (uint16_t)CYCLES_PER_S + (f >> 1);
    uint8_t i = 16;
    do {
        hi <<= 1;
        if (lo & 0x8000) hi++;
        lo <<= 1;
        if (hi >= f) {
            hi -= f;
            lo++;
        }
    } while (--i);
    return HAL_PERIOD(lo);
}

/* The index (RAMP_INDEX) of the highest ramp level of the shape $1 whose
 * step period is longer than p (in the timer's form, HAL_PERIOD), found by
 * the periods the step interrupt runs, so no table of rates is needed: the
 * fastest level slower than the rate of p.  Strictly longer, as periods are
 * rounded to whole cycles: a level whose period rounds to p may be a little
 * faster than the rate asked for (9050 steps/s for 9000, both 102 cycles),
 * and the climb must not go past the feed.
 *
 * Also leaves in plan.exit_brake the hold steps (times the multiplier) of
 * the levels up to it, which the step interrupt takes off the braking
 * distance: the segment ends as it reaches that level.  Level 0 takes off
 * nothing, so a stop runs level 0's hold at the start rate, as a start
 * does.  A leaf, so that SDCC overlays its locals. */
static uint8_t level_for_period(uint16_t p)
{
    uint8_t i = RAMP_INDEX(0, SETTING(SET_SHAPE));
    uint8_t j, hi;
    uint16_t sum = 0;
    for (;;) {
        sum += (uint16_t)((uint8_t)ramp_hold[i] * (uint8_t)SETTING(SET_ACCEL));   /* MUL AB */
        j = i + RAMP_STEP;                /* the next level up, if there is one */
        if (j >= RAMP_SHAPES * RAMP_LEVELS) break;
        hi = RAMP_HI_SHORT;
        if (j < RAMP_HI_LEVELS) hi = ramp_period_hi[j];
        if (!HAL_PERIOD_LONGER(RAMP_PERIOD(hi, ramp_period_lo[j]), p)) break;
        i = j;
    }
    /* Not ?: (nor a bit in an expression below): SDCC keeps such a
     * condition in a bit of RAM of its own, and the bit segment is full. */
    if (!RAMP_ABOVE_START(i)) sum = 0;
    plan.exit_brake = sum;
    return i;
}

/* Rate v brought within FEED_MIN..hi. */
static uint16_t rate_within(uint16_t v, uint16_t hi)
{
    if (v > hi) v = hi;
    if (v < FEED_MIN) v = FEED_MIN;
    return v;
}

/* Ramp fields shared by lines and arcs, then into the queue.  The exit is
 * no faster than the feed; a stop (0) counts as FEED_MIN, whose period is
 * far longer than level 1's: level 0. */
static uint8_t plan_motion(uint16_t top)
{
    uint16_t f = plan_arg[PLAN_FEED];
    if (f == 0) f = SETTING(SET_FEED);
    f = rate_within(f, top);
    plan.cruise = level_for_period(plan.cruise_period = period_of(f));
    /* The exit's period is divided out even when it equals the feed's:
     * skipping that (500-600 machine cycles, period_of's 16 rounds in
     * build/mcs51/planner.rst) costs 28 bytes of the last 57 of flash. */
    plan.exit = level_for_period(period_of(rate_within(plan_arg[PLAN_EXIT], f)));  /* its exit_brake stays */
    return commit();
}

/* (&plan.a)[k] = |plan_arg[k]|; sets dir_bit in plan.dirs if it is negative. */
static void magnitude(uint8_t k, uint8_t dir_bit)
{
    int16_t v = (int16_t)plan_arg[k];
    if (v < 0) {
        plan.dirs |= dir_bit;
        v = -v;
    }
    (&plan.a)[k] = v;
}

#ifdef INTERP_DDA
/* The DDA's capacity for integrands up to v: the smallest power of two
 * above v (the integrators normalised: the largest integrand's top bit is
 * the register's), at most 2^15.  For an arc its exponent n also goes into
 * the high nibble of plan.dirs, for the step interrupt. */
static uint16_t dda_capacity(uint16_t v, uint8_t arc)
{
    uint16_t cap = 1;
    uint8_t n = 0;
    while (cap <= v && !(cap & 0x8000)) {
        cap <<= 1;
        n += 0x10;
    }
    if (arc) {
        plan.dirs |= n;
    }
    return cap;
}
#endif

uint8_t planner_line(void)
{
    if (plan_arg[0] == 0 && plan_arg[1] == 0) {
        return E_OK;                /* nothing to move */
    }
    plan.kind = SEG_LINE;
    plan.dirs = 0;
    magnitude(0, BIT_X_DIR);
    magnitude(1, BIT_Y_DIR);
#if defined(INTERP_COMPARE)
    plan.steps = plan.a > plan.b ? plan.a : plan.b;     /* the base axis steps every time */
#elif defined(INTERP_DDA)
    /* The integrators' capacity (in c, free in a line), above both counts
     * (the larger's bit length: a | b has it); as many iterations as it. */
    plan.c = (int16_t)dda_capacity(plan.a | plan.b, 0);
    plan.steps = plan.c;
#else
    plan.steps = (uint16_t)plan.a + (uint16_t)plan.b;
#endif
#ifdef ZAXIS
    plan.c = 0;                     /* not a Z move */
#endif
    return plan_motion(LINE_TOP);
}

#ifdef ZAXIS
/* A Z move: a line along Y (so the interrupt's line code runs it, the ramp
 * included) with c = 1, which sends its pulses to the Z pins. */
uint8_t planner_z(void)
{
    if (plan_arg[0] == 0) {
        return E_OK;
    }
    plan.kind = SEG_LINE;
    plan.dirs = 0;
    magnitude(0, BIT_Z_DIR);
    plan.b = plan.a;
    plan.a = 0;
    plan.c = 1;
    plan.steps = plan.b;
    return plan_motion(LINE_TOP);
}
#endif

/* Quadrant 0..3 (I..IV) of a point (x, y) = (p[0], p[1]) relative to the
 * centre.  A point on an axis belongs to the quadrant the arc is about to
 * sweep through, so the point where an arc crosses an axis already counts
 * as the next quadrant.  The centre itself has no quadrant: 4.  Indexed by
 * the signs of x and y (negative, zero, positive = 0, 1, 2) as 3 * x + y;
 * the quadrant when turning counter-clockwise in bits 0-2, clockwise in
 * bits 4-6. */
#define QUADRANT(ccw, cw) ((ccw) | ((cw) << 4))
static RAMP_ROM uint8_t quadrants[9] = {
    QUADRANT(2, 2), QUADRANT(2, 1), QUADRANT(1, 1),     /* x < 0 */
    QUADRANT(3, 2), QUADRANT(4, 4), QUADRANT(1, 0),     /* x = 0 */
    QUADRANT(3, 3), QUADRANT(0, 3), QUADRANT(0, 0),     /* x > 0 */
};

static uint8_t arc_quadrant(IDATA int16_t *p)
{
    uint8_t k = 0, n = 2;
    do {
        k *= 3;
        if (*p >= 0) {
            k++;
            if (*p) k++;
        }
        p++;
    } while (--n);
    k = quadrants[k];
    if (arc_cw) k >>= 4;
    return (uint8_t)(k & 0x0F);
}

/* arc_t = 0: the call takes 3 bytes of code, the assignment 9 */
static void clear_t(void)
{
    arc_t = 0;
}

/* arc_t += a * b */
static void add_product(int16_t a, int16_t b)
{
    arc_t += HAL_MUL16S(a, b);
}

#ifndef INTERP_COMPARE
/* Adds to arc_t the steps of the staircase between point p (p[0], p[1])
 * and the point at radius arc_r on half-axis k + arc_cw (+X, +Y, -X, -Y =
 * 0..3 modulo 4: only whether it is an X or a Y axis counts) bounding the
 * point's quadrant: the staircase moves monotonically, and the point lies
 * on the axis's side of the centre.  Coordinates and radius are at most
 * 32767. */
static void add_axis_steps(uint8_t k, IDATA int16_t *p)
{
    int16_t v;
    uint8_t n = 2;
    k = (uint8_t)(k + arc_cw) & 1;      /* counts down to the coordinate along the axis */
    do {
        v = *p++;
        if (v < 0) v = -v;
        if (k-- == 0) {
            v -= arc_r;
            if (v < 0) v = -v;
        }
        arc_t += (uint16_t)v;
    } while (--n);
}
#endif

/* arc_t += p[0]^2 + p[1]^2 */
static void add_squares(IDATA int16_t *p)
{
    IDATA int16_t *end = p + 2;
    do {
        add_product(*p, *p);
    } while (++p != end);
}

/* Start and end relative to the centre: (-i, -j) and (dx - i, dy - j);
 * E_RANGE if the end is outside -32767..32767. */
static uint8_t arc_points(void)
{
    IDATA uint16_t *arg = plan_arg;     /* dx, then dy; i, j two further */
    IDATA int16_t *pt = &plan.a;        /* start x, then y; the end two further */
    uint16_t i, e;
    uint8_t dh;
    do {
        i = arg[2];
        e = arg[0] - i;
        dh = (uint8_t)(arg[0] >> 8);
        /* out of range: d - i overflowed 16 bits (the operands' signs
         * differ, and the result's differs from d's), or is -32768 */
        if (((uint8_t)(dh ^ (uint8_t)(i >> 8)) & (uint8_t)(dh ^ (uint8_t)(e >> 8)) & 0x80) || e == 0x8000) {
            return E_RANGE;
        }
        pt[2] = (int16_t)e;
        pt[0] = (int16_t)(0 - i);
        arg++;
    } while (++pt != &plan.c);
    return E_OK;
}

/* Start and end in one quadrant, the final one: the moves towards the end
 * (into plan.dirs, see segment.h) and the exact step count (into arc_t).
 * Same quadrant: each difference is at most 32767, their sum fits 16 bits. */
static void arc_final_quadrant(void)
{
    IDATA int16_t *p = &plan.a;         /* start x, y, end x, y */
    uint8_t move = MV_XP, dirs = 0;
    int16_t e;
    uint16_t sum = 0;
    do {
        e = p[2] - p[0];
        p++;
        if (e < 0) {
            dirs |= move << 1;          /* MV_XN, MV_YN */
            e = -e;
        } else if (e) {
            dirs |= move;
        }
        sum += (uint16_t)e;
        move <<= 2;                     /* MV_YP */
    } while (move != MV_YP << 2);
    plan.dirs = dirs;
    arc_t = sum;
}

#ifdef INTERP_COMPARE
/* The iterations comparison-integration takes from the half-axis where
 * quadrant k (0..3) starts to point pt on the circle, with p the point's
 * distance from that axis and q its distance along it: the base axis is
 * the one along which the point moves faster, so p while q >= p, past the
 * 45-degree point (d, d), d = R / sqrt 2, then 2d - q. */
static uint16_t arc_potential(uint8_t k, IDATA int16_t *pt)
{
    uint16_t p = (uint16_t)(pt[1] < 0 ? -pt[1] : pt[1]);
    uint16_t q = (uint16_t)(pt[0] < 0 ? -pt[0] : pt[0]);
    uint16_t t;
    if ((uint8_t)(k + arc_cw) & 1) {        /* starts on the Y axis */
        t = p;
        p = q;
        q = t;
    }
    if (q >= p) {
        return p;
    }
    /* 2d = R * 362/256, by MUL AB (a call would cost this leaf function
     * its overlaid locals) */
    t = (uint16_t)((uint8_t)(arc_r >> 8) * (uint8_t)106) + (uint8_t)((uint16_t)((uint8_t)arc_r * (uint8_t)106) >> 8);
    return arc_r + t - q;
}
#endif

uint8_t planner_arc(uint8_t clockwise)
{
    uint8_t qe, cross;
    uint16_t w;

    arc_cw = clockwise ? 1 : 0;
    if (arc_points()) return E_RANGE;
    clear_t();
    add_squares(&plan.a);                   /* R^2, at most 2 * 32767^2 */
    arc_sqrt();
    if (arc_r == 0) return E_ARC;           /* the centre is the start point */
    if (arc_r & 0x8000) return E_RANGE;     /* above 32767 */
    /* The end more than a step off the circle, |E^2 - R^2| > w = 2r + 1:
     * E^2 - R^2 + w outside 0..2w, as unsigned, above 2w. */
    w = 2u * arc_r + 1u;
    arc_t = w - arc_t;
    add_squares(&plan.c);
    if (arc_t > (uint32_t)w + w) return E_ARC;

    qe = SEG_ARC_CCW;                       /* an if: see level_for_period */
    if (arc_cw) qe = SEG_ARC_CW;
    plan.kind = qe;
    /* plan.quadrant gets its 4 if clockwise (segment.h) at once: what
     * follows takes it modulo 4, or only its parity */
    qe = arc_quadrant(&plan.a);
    if (arc_cw) qe |= 4;
    plan.quadrant = qe;
    qe = arc_quadrant(&plan.c);
    cross = (uint8_t)(qe - plan.quadrant);
    if (arc_cw) cross = (uint8_t)-cross;
    cross &= 3;
    if (cross == 0) {
        /* Same quadrant: ahead of the start, or all the way round?  The
         * cross product start x end says which side the end lies on. */
        clear_t();
        add_product(plan.a, plan.d);
        add_product(-plan.b, plan.c);
        if (arc_cw) arc_t = 0 - arc_t;
        /* behind (arc_t < 0), or the start itself (dx = dy = 0) */
        if (((uint8_t)(arc_t >> 24) & 0x80) || !(plan_arg[0] | plan_arg[1])) {
            cross = 4;
        }
    }
    plan.crossings = cross;                 /* and from here on read there */
    if (cross == 0) {
        arc_final_quadrant();
    }
#ifndef INTERP_COMPARE
    else {
        /* Quadrant q runs from half-axis q to q+1 counter-clockwise, q+1 to q
         * clockwise: the start leaves its quadrant through the second (the
         * same axis as q + 1 + arc_cw), the end enters its own through the
         * first.  Between the start's and the end's quadrants lie cross - 1
         * whole quadrants of 2r steps each (r at most 32767). */
        clear_t();
        add_axis_steps((uint8_t)(plan.quadrant + 1), &plan.a);
        /* An end at the centre (qe = 4): |c| + |d| = 0; its steps are r
         * clockwise (to the +Y half-axis), none counter-clockwise. */
        if (qe != 4 || arc_cw) {
            add_axis_steps(qe, &plan.c);
        }
        add_product((int16_t)arc_r, (uint8_t)(plan.crossings + plan.crossings - 2));
    }
#endif
#if defined(INTERP_DDA)
    /* The count is of iterations, not steps, and rounded down: a count that
     * runs out early costs a little braking early, one that ran out late
     * would brake too late.  An iteration of the DDA covers 1 to 1.414 times
     * R / 2^n of these steps, where the capacity 2^n is the smallest power
     * of two above R + 1 (the DDA strays up to about 1.4 steps off the
     * circle): from a half-axis to any angle of the quadrant (the pieces of
     * an arc that crosses one) at least 1 / 0.764 of them (at 67 degrees),
     * within a quadrant at least 1 / 0.707 (near 45 degrees). */
    plan.dirs &= 0x0F;
    qe = plan.crossings ? 193 : 181;
    arc_r = (uint16_t)(((uint32_t)dda_capacity(arc_r + 1, 1) * qe) / arc_r);   /* the radius is done with */
    arc_t = (arc_t * arc_r) >> 8;
#elif defined(INTERP_COMPARE)
    /* The count is of iterations: the end's share of its quadrant (also
     * the count in the final quadrant, queue_final), less the start's of its
     * own, plus cross whole quadrants (2d each). */
    arc_t = (qe == 4) ? 0 : arc_potential(qe, &plan.c);
    queue_final[q_head] = arc_t > 2 ? (uint16_t)arc_t - 2 : 1;   /* 2 less: the staircase may take fewer */
    arc_t -= arc_potential(plan.quadrant, &plan.a);
    plan_arg[0] = 0;                        /* a half-axis point; plan_arg[0..3]: free after arc_points */
    plan_arg[1] = arc_r;
    for (qe = plan.crossings; qe; qe--) {
        arc_t += arc_potential(arc_cw, (IDATA int16_t *)plan_arg);
    }
#endif
#ifdef INTERP_DIAGONAL
    arc_t -= 2;                             /* the staircase of a small radius may take fewer */
    if ((int32_t)arc_t < 1) {
        arc_t = 1;
    }
#endif
    w = (uint16_t)arc_t;
    if ((uint16_t)(arc_t >> 16)) w = 65535u;
    plan.steps = w;
    return plan_motion(ARC_TOP);
}

/* Pen and dwell: wait plan.steps milliseconds. */
static uint8_t plan_wait(void)
{
    plan.cruise = 0;                    /* unused: a wait has no ramp */
    plan.exit = 0;
    plan.cruise_period = HAL_PERIOD(DWELL_PERIOD);
    plan.exit_brake = 0;
    return commit();
}

uint8_t planner_pen(uint8_t down)
{
    plan.kind = SEG_PEN;
    if (down) down = BIT_PEN;
    plan.dirs = down;
    plan.steps = SETTING(SET_PEN);      /* 1..5000: the protocol checks $3 */
    return plan_wait();
}

uint8_t planner_dwell(uint16_t ms)
{
    if (ms == 0) {
        return E_OK;
    }
    plan.kind = SEG_DWELL;
    plan.dirs = 0;
    plan.steps = ms;
    return plan_wait();
}

#ifdef FOLLOW
/* F: its arguments in follow_args (set at rest: nothing runs while an F
 * is queued, and an F is queued only at rest), the feed at PLAN_FEED (0:
 * the ramp's start rate, which is also the most: follow.h).  The segment
 * carries the feed's period; follow_service starts the steering. */
uint8_t planner_follow(void)
{
    uint8_t n;
    plan.kind = SEG_FOLLOW;
    plan.steps = 1;                     /* never counted down: follow_next ends it */
    plan.cruise = 0;
    plan.exit = 0;
    plan.cruise_period = period_of(rate_within(plan_arg[PLAN_FEED] ? plan_arg[PLAN_FEED] : RAMP_R0, RAMP_R0));
    plan.exit_brake = 0;
    n = commit();
    if (n == E_OK) follow_next = FOLLOW_QUEUED;
    return n;
}
#endif
