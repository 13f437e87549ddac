/* stepper.c - the step interrupt.
 *
 * Each interrupt first emits the step computed by the previous one (so the
 * pulse edge is not delayed by the arithmetic), then computes the next step:
 * which axis, which direction, and how long until it is due.  Everything here
 * is additions, comparisons and table look-ups; the planner did the rest.
 *
 * Lines: point-by-point comparison (seed 002, 000 ch. 2).  With |dx|, |dy| and
 * F starting at 0: F >= 0 steps X and subtracts |dy|, F < 0 steps Y and adds
 * |dx|; after |dx| + |dy| steps the end point is reached exactly.
 *
 * Arcs: F = x^2 + y^2 - R^2 relative to the centre, updated incrementally
 * (stepping x to x+1 adds 2x+1).  The quadrant decides which two moves are
 * possible (seed 000 table 2.2); F's sign picks one.  When the moving
 * coordinate reaches 0 the arc has crossed an axis into the next quadrant.
 * In the final quadrant a move is only taken if it does not pass the end
 * coordinate on its axis, so the end point is reached exactly even when the
 * programmed end lies a fraction of a step off the circle.
 *
 * Ramp: the speed is a level of the ramp table, held for a table number of
 * steps (times the acceleration multiplier) before moving one level up or
 * down.  st_brake is the number of steps needed to fall from the current
 * level to the segment's exit level, kept up to date by additions only. */
#include "stepper.h"
#include "planner.h"
#include "ramp.h"

FAST volatile int32_t pos_x, pos_y;
FAST volatile uint8_t st_running, st_paused, st_hold;
FAST volatile uint16_t st_seq;
FAST volatile uint8_t st_port;
FAST volatile uint8_t st_level;
FAST volatile uint16_t st_underruns;
FAST uint8_t st_accel = 1;
FAST uint8_t st_shape = RAMP_TRAPEZOID;

static FAST uint8_t st_kind;          /* SEG_* of the current segment, 0 when none */
static FAST uint8_t st_pulse;         /* step bits to emit at the next interrupt */
static FAST uint16_t st_period;       /* cycles from the next pulse to the one after */
static FAST uint16_t st_left;         /* steps (or ms) left in the segment */
static FAST int16_t st_a, st_b;       /* line: |dx|, |dy| */
static FAST int16_t st_lf;            /* line: deviation F */
static FAST int16_t st_x, st_y;       /* arc: position relative to the centre */
static FAST int16_t st_xe, st_ye;     /* arc: end relative to the centre */
static FAST int32_t st_af;            /* arc: deviation F = x^2 + y^2 - R^2 */
static FAST uint8_t st_q;             /* arc: current quadrant 0..3 */
static FAST uint8_t st_cross;         /* arc: axis crossings before the final quadrant */
static FAST uint8_t st_mv_pos, st_mv_neg;  /* arc: move for F >= 0 and for F < 0 */
static FAST uint8_t st_end_axis;      /* arc: half-axis that ends this quadrant: +X, +Y, -X, -Y = 0..3 */
static FAST uint8_t st_cruise, st_exit;
static FAST uint16_t st_cruise_period;
static FAST int16_t st_brake;         /* steps to fall from this level to the exit level */
static FAST uint16_t st_below;        /* hold steps of all the levels below this one */
static FAST uint16_t st_level_left;   /* steps left at the current level */
static RAMP_ROM uint16_t *FAST st_periods;
static RAMP_ROM uint8_t *FAST st_holds;

#define MV_XP 0
#define MV_XN 1
#define MV_YP 2
#define MV_YN 3

/* [clockwise?][quadrant][F < 0]: seed 000 table 2.2, with quadrant I..IV = 0..3 */
static RAMP_ROM uint8_t arc_moves[2][4][2] = {
    { {MV_XN, MV_YP}, {MV_YN, MV_XN}, {MV_XP, MV_YN}, {MV_YP, MV_XP} },  /* counter-clockwise */
    { {MV_YN, MV_XP}, {MV_XP, MV_YP}, {MV_YP, MV_XN}, {MV_XN, MV_YN} },  /* clockwise */
};

#define HOLD_STEPS(level) ((uint16_t)((uint8_t)st_holds[level] * (uint8_t)st_accel))  /* MUL AB */

void stepper_init(void)
{
    pos_x = 0;
    pos_y = 0;
    st_port = HAL_PORT_IDLE;
    st_running = 0;
    st_paused = 0;
    st_hold = 0;
    st_underruns = 0;
    stepper_abort();
    HAL_PORT_OUT(st_port);
}

void stepper_abort(void)
{
    st_kind = 0;
    st_left = 0;
    st_pulse = 0;
    st_level = 0;
    st_running = 0;
    st_paused = 0;
}

void stepper_start(void)
{
    st_periods = ramp_period[st_shape];
    st_holds = ramp_hold[st_shape];
    st_kind = 0;
    st_left = 0;
    st_pulse = 0;
    st_level = 0;
    st_below = 0;
    st_level_left = HOLD_STEPS(0);
    st_paused = 0;
    st_running = 1;
    HAL_TIMER_START(64);
}

void stepper_resume(void)
{
    st_hold = 0;
    if (st_paused) {
        st_paused = 0;
        HAL_TIMER_START(64);
    }
}

INLINE void set_arc_moves(void)
{
    uint8_t cw = (st_kind == SEG_ARC_CW);
    st_mv_pos = arc_moves[cw][st_q][0];
    st_mv_neg = arc_moves[cw][st_q][1];
    st_end_axis = cw ? st_q : ((st_q + 1) & 3);
}

/* Has the arc reached the half-axis that ends its quadrant?  Testing the
 * point, not the last move, keeps radius 1 right: its staircase passes
 * through the centre, which lies on every axis and ends no quadrant. */
#define AT_END_AXIS() ((st_end_axis & 1)                                       \
        ? (st_x == 0 && ((st_end_axis & 2) ? st_y < 0 : st_y > 0))            \
        : (st_y == 0 && ((st_end_axis & 2) ? st_x < 0 : st_x > 0)))

/* Copy the next queued segment into the interrupt's working set.
 * Returns 0 when the queue is empty. */
INLINE uint8_t load_segment(void)
{
    XDATA segment_t *s;
    if (q_tail == q_head) {
        return 0;
    }
    s = &queue[q_tail];
    st_kind = s->kind;
    st_seq = s->seq;
    st_left = s->steps;
    if (st_kind == SEG_LINE) {
        st_a = s->a;
        st_b = s->b;
        st_lf = st_a ? 0 : -1;   /* a pure Y move must never take the F >= 0 branch */
        st_port = (st_port & ~(BIT_X_DIR | BIT_Y_DIR)) | s->dirs;
    } else if (st_kind == SEG_PEN || st_kind == SEG_DWELL) {
        if (st_kind == SEG_PEN) {
            st_port = (st_port & ~BIT_PEN) | s->dirs;
        }
        st_kind = SEG_DWELL;
        st_level = 0;
        st_below = 0;
        st_level_left = HOLD_STEPS(0);
    } else {
        st_x = s->a;
        st_y = s->b;
        st_xe = s->c;
        st_ye = s->d;
        st_af = 0;
        st_q = s->quadrant;
        st_cross = s->crossings;
        set_arc_moves();
    }
    st_cruise = s->cruise;
    st_cruise_period = s->cruise_period;
    st_exit = s->exit;
    st_brake = (int16_t)(st_below - s->exit_brake);
    q_tail = QUEUE_NEXT(q_tail);
    if (st_exit && q_tail == q_head) {
        /* Nothing follows yet: plan to stop rather than run off the queue's end. */
        st_exit = 0;
        st_brake += (int16_t)(s->exit_brake - HOLD_STEPS(0));
        st_underruns++;
    }
    HAL_SEGMENT_STARTED(st_seq);
    return 1;
}

/* Does move mv head towards the end coordinate on its axis? */
#define MV_TOWARDS_END(mv) (((mv) & 1) ? ((mv) & 2 ? st_y > st_ye : st_x > st_xe) \
                                       : ((mv) & 2 ? st_y < st_ye : st_x < st_xe))

/* Pick the arc's next move; in the final quadrant never pass the end. */
INLINE uint8_t arc_next_move(void)
{
    uint8_t mv = st_af < 0 ? st_mv_neg : st_mv_pos;
    if (st_cross || MV_TOWARDS_END(mv)) {
        return mv;
    }
    mv = (mv == st_mv_pos) ? st_mv_neg : st_mv_pos;
    if (MV_TOWARDS_END(mv)) {
        return mv;
    }
    /* The end lies just off the staircase: walk straight onto it. */
    if (st_x != st_xe) {
        return st_x < st_xe ? MV_XP : MV_XN;
    }
    return st_y < st_ye ? MV_YP : MV_YN;
}

STEPPER_ISR
{
    uint8_t mv;
    int16_t c;

    HAL_TIMER_ADVANCE(st_period);
    if (st_pulse) {
        HAL_PORT_OUT(st_port | st_pulse);
        if (st_pulse & BIT_X_STEP) {
            if (st_port & BIT_X_DIR) pos_x--; else pos_x++;
        }
        if (st_pulse & BIT_Y_STEP) {
            if (st_port & BIT_Y_DIR) pos_y--; else pos_y++;
        }
        HAL_PORT_OUT(st_port);
        st_pulse = 0;
    }

    if (st_left == 0) {
        if (!load_segment()) {
            HAL_TIMER_HALT();
            st_kind = 0;
            st_level = 0;
            st_running = 0;
            return;
        }
        HAL_PORT_OUT(st_port);   /* directions and pen settle a whole period before the pulse */
        if (st_left == 0) {
            st_period = 64;      /* empty segment: look again shortly */
            return;
        }
    }

    if (st_kind == SEG_DWELL) {
        st_period = DWELL_PERIOD;
        st_left--;
        return;
    }

    if (st_hold && st_level == 0) {
        /* Feed hold has slowed to the start rate: stop here, resume later. */
        HAL_TIMER_HALT();
        st_paused = 1;
        return;
    }

    if (st_kind == SEG_LINE) {
        if (st_lf >= 0) {
            st_pulse = BIT_X_STEP;
            st_lf -= st_b;
        } else {
            st_pulse = BIT_Y_STEP;
            st_lf += st_a;
        }
        st_left--;
    } else {
        mv = arc_next_move();
        /* F = x^2 + y^2 - R^2 changes by 2c+1 when c becomes c+1, by -2c+1 when c becomes c-1. */
        if (mv & 2) {
            c = st_y;
            st_pulse = BIT_Y_STEP;
        } else {
            c = st_x;
            st_pulse = BIT_X_STEP;
        }
        if (mv & 1) {
            c = -c;
            st_port |= (uint8_t)(st_pulse << 1);           /* direction bit sits above its step bit */
        } else {
            st_port &= (uint8_t)~(st_pulse << 1);
        }
        st_af += ((int32_t)c << 1) + 1;
        if (mv == MV_XP) st_x++;
        else if (mv == MV_XN) st_x--;
        else if (mv == MV_YP) st_y++;
        else st_y--;
        if (st_cross) {
            if (AT_END_AXIS()) {
                st_q = (st_kind == SEG_ARC_CW) ? ((st_q + 3) & 3) : ((st_q + 1) & 3);
                set_arc_moves();
                if (--st_cross == 0) {
                    /* Final quadrant: the remaining count is now exact. */
                    st_left = (uint16_t)((st_x > st_xe ? st_x - st_xe : st_xe - st_x) +
                                         (st_y > st_ye ? st_y - st_ye : st_ye - st_y));
                }
            }
            if (st_cross && st_left > 1) {
                st_left--;
            }
        } else if (st_x == st_xe && st_y == st_ye) {
            st_left = 0;
        } else if (st_left > 1) {
            st_left--;
        }
        HAL_PORT_OUT(st_port);   /* direction set a whole period before its pulse */
    }

    /* Ramp: brake to the exit level in time, else climb to the cruise level. */
    if (st_level && (st_hold || st_level > st_cruise ||
                     (st_level > st_exit && (int16_t)st_left <= st_brake + (int16_t)st_level_left))) {
        if (--st_level_left == 0) {
            st_level--;
            st_level_left = HOLD_STEPS(st_level);
            st_brake -= st_level_left;
            st_below -= st_level_left;
        }
        st_period = st_periods[st_level];
    } else if (st_level < st_cruise && !st_hold) {
        if (--st_level_left == 0) {
            st_level_left = HOLD_STEPS(st_level);
            st_brake += st_level_left;
            st_below += st_level_left;
            st_level++;
            st_level_left = HOLD_STEPS(st_level);
        }
        st_period = st_periods[st_level];
    } else {
        st_period = st_cruise_period;
    }
}
