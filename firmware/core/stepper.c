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
 * possible (seed 000 table 2.2); F's sign picks one.  When the arc reaches
 * the half-axis that ends its quadrant it has crossed into the next one.
 * In the final quadrant a move is only taken if it heads towards the end
 * coordinate on its axis, so the end point is reached exactly even when the
 * programmed end lies a fraction of a step off the circle; every move there
 * brings the end one step closer, so the step count is exact too.
 *
 * Ramp: the speed is a level of the ramp table, held for a table number of
 * steps (times the acceleration multiplier) before moving one level up or
 * down.  st_brake_at is the number of steps left at which braking from the
 * current level must begin to arrive at the segment's exit level on its last
 * step; it is kept up to date by additions only.
 *
 * Build options (README.md) replace parts of this with other code:
 * INTERP_DDA and INTERP_COMPARE the interpolation (see the comments at their
 * code: the ramp, the queue and the quadrant logic stay), DRIVE_PHASE the
 * pulse outputs (the windings' phase patterns instead of step pulses), and
 * ZAXIS adds a third axis, moved alone by lines along Y whose pulses go to
 * the Z pins.
 *
 * This runs up to some ten thousand times a second on a 1 MIPS core, and
 * SDCC compiles it as written: hence the copy of the segment in direct RAM,
 * flags as bits, one-hot arc moves, flat ramp tables indexed by one byte,
 * and a fast path for the steps at cruise speed (tools/bench.py measures
 * it).  It must call no function (SDCC's support routines included):
 * everything it uses is a macro or INLINE. */
#include "stepper.h"
#include "serial.h"
#include "planner.h"
#include "ramp.h"
#ifdef FOLLOW
#include "follow.h"
#endif

/* ST_STATE: the interrupt's own state, static unless the HAL brings the
 * interrupt itself (HAL_STEPPER_ISR_EXTERNAL), which then shares it. */
#ifdef HAL_STEPPER_ISR_EXTERNAL
#define ST_STATE
#else
#define ST_STATE static
#endif

volatile FLAG st_running, st_paused, st_hold;
IDATA volatile uint16_t st_underruns;

#ifdef HAL_STEP_PERIOD
#define st_period HAL_STEP_PERIOD         /* the timer's own reload register */
#else
static FAST uint16_t st_period;       /* HAL_PERIOD form: from the next pulse to the one after */
#endif
#if defined(INTERP_DDA)
static FAST uint16_t st_jx, st_jy;    /* the X and Y integrators' remainders, 0..st_cap-1 */
static FAST uint16_t st_cap;          /* their capacity, a power of two: reaching it is a step */
#elif defined(INTERP_COMPARE)
static FAST union {
    int32_t arc;                      /* arc: deviation F = x^2 + y^2 - R^2 */
    int16_t line;                     /* line: deviation F */
} st_f;
#define st_af st_f.arc
#define st_lf st_f.line
static FLAG st_ybase;                 /* line: Y is the base axis, the one that steps every time */
#else
/* Defined in this order, first after the bits, the board's image has the
 * sign bytes of both F in bit-addressable RAM, where the hand-made step
 * interrupt tests them with one instruction. */
ST_STATE FAST int16_t st_lf;            /* line: deviation F */
ST_STATE FAST int32_t st_af;            /* arc: deviation F = x^2 + y^2 - R^2 */
#endif
FAST int32_t pos_x, pos_y;
#ifdef ZAXIS
XDATA int32_t pos_z;
#endif
FAST segment_t st_seg;
FAST volatile uint8_t st_port;
FAST volatile uint8_t st_level;
#ifdef DRIVE_PHASE
static XDATA uint8_t st_phase_y;      /* the Y windings' pattern (no byte of internal RAM is left) */
#endif
#ifdef INTERP_DDA
ST_STATE FAST uint8_t st_moves;         /* arc: the quadrant's two moves, both arc_moves nibbles */
#else
ST_STATE FAST uint8_t st_moves;         /* arc: the quadrant's arc_moves entry */
#endif
ST_STATE FAST uint16_t st_level_left;   /* steps left at the current level */
ST_STATE IDATA uint16_t st_below;       /* hold steps of all the levels below this one */
ST_STATE FAST uint16_t st_brake_at;     /* braking must have begun once steps left <= this */
ST_STATE FAST uint16_t st_cruise_to;    /* cruising: nothing to do while steps left > this */
ST_STATE FAST uint8_t st_cruise_lo, st_cruise_hi;  /* cruising: steps to the braking point, see CRUISE_SET */
ST_STATE FLAG st_pulse_x, st_pulse_y;   /* step to emit at the next interrupt */
ST_STATE FLAG st_load;                  /* the segment is done: load the next one */
ST_STATE FLAG st_line;                  /* the segment is a line */
ST_STATE FLAG st_cruising;              /* at the cruise level with its period set */
ST_STATE FLAG st_stale;                 /* st_period is not the current level's table period */
ST_STATE FLAG st_end_x0;                /* arc: the quadrant ends on the Y axis, where x reaches 0 */
ST_STATE FLAG st_end_neg;               /* arc: ... on its negative half */
#ifdef ZAXIS
static FLAG st_zmove;                 /* the line is a Z move: its Y steps go to Z */
#endif

#ifndef HAL_STEPPER_ISR_EXTERNAL
/* Per quadrant index (4 if clockwise, plus quadrant I..IV = 0..3): the move
 * for F >= 0 in the low nibble, for F < 0 in the high nibble (seed 000
 * table 2.2). */
#define MOVES(pos, neg) ((uint8_t)((pos) | ((neg) << 4)))
#ifndef INTERP_DDA
static RAMP_ROM uint8_t arc_moves[8] = {
    MOVES(MV_XN, MV_YP), MOVES(MV_YN, MV_XN), MOVES(MV_XP, MV_YN), MOVES(MV_YP, MV_XP), /* ccw */
    MOVES(MV_YN, MV_XP), MOVES(MV_XP, MV_YP), MOVES(MV_YP, MV_XN), MOVES(MV_XN, MV_YN), /* cw */
};
#endif
#ifdef INTERP_DDA
/* Per quadrant index: both moves of the quadrant, as arc_moves would give them. */
#define BOTH(moves) ((uint8_t)(((moves) | ((moves) >> 4)) & 0x0F))
static RAMP_ROM uint8_t arc_both[8] = {
    BOTH(MOVES(MV_XN, MV_YP)), BOTH(MOVES(MV_YN, MV_XN)), BOTH(MOVES(MV_XP, MV_YN)), BOTH(MOVES(MV_YP, MV_XP)),
    BOTH(MOVES(MV_YN, MV_XP)), BOTH(MOVES(MV_XP, MV_YP)), BOTH(MOVES(MV_YP, MV_XN)), BOTH(MOVES(MV_XN, MV_YN)),
};
#endif
/* Per quadrant index: the half-axis that ends the quadrant (+X, +Y, -X, -Y =
 * 0..3) in bits 0-1, the index of the quadrant after it in bits 4-6.  Quadrant
 * q runs from half-axis q to q+1 counter-clockwise, from q+1 to q clockwise. */
#define TURN(axis, next) ((axis) | ((next) << 4))
static RAMP_ROM uint8_t arc_turns[8] = {
    TURN(1, 1), TURN(2, 2), TURN(3, 3), TURN(0, 0),     /* ccw */
    TURN(0, 7), TURN(1, 4), TURN(2, 5), TURN(3, 6),     /* cw */
};

#endif

#ifdef DRIVE_PHASE
/* The winding pattern after each pattern: forwards (towards +) at the
 * pattern, backwards at PHASE_SPAN plus the pattern; the patterns that are
 * not in the sequence lead to its first. */
#define PHASE_SPAN (PHASE_BITS + 1)
static RAMP_ROM uint8_t phase_next[2 * PHASE_SPAN] = {
#if defined(DRIVE_PHASE3)
    /* single excitation A, B, C (A = bit 0, B = bit 1, C = bit 2) */
    1, 2, 4, 1, 1, 1, 1, 1,
    1, 4, 1, 1, 2, 1, 1, 1,
#elif defined(DRIVE_PHASE3D)
    /* double excitation A, AB, B, BC, C, CA */
    1, 3, 6, 2, 5, 1, 4, 1,
    1, 5, 3, 1, 6, 4, 2, 1,
#else
    /* two-phase unipolar, half steps A, AB, B, BA', A', A'B', B', B'A
     * (A = bit 0, B = bit 1, A' = bit 2, B' = bit 3) */
    1, 3, 6, 2, 12, 1, 4, 1, 9, 1, 1, 1, 8, 1, 1, 1,
    1, 9, 3, 1, 6, 1, 2, 1, 12, 8, 1, 1, 4, 1, 1, 1,
#endif
};
#endif

#ifdef INTERP_DDA
/* A lower bound of the iterations an arc takes from a half-axis for s
 * point-by-point steps (planner.c): s * 193 / 256 by two MUL AB, leaving
 * out the factor 2^n / R, which is above 1. */
#define ARC_ITERATIONS(s) ((uint16_t)((uint8_t)((s) >> 8) * (uint8_t)193) + \
                           (uint8_t)((uint16_t)((uint8_t)(s) * (uint8_t)193) >> 8))
#endif

#ifdef INTERP_COMPARE
/* 2c + 1 in 32 bits, the change of F when coordinate c becomes c + 1
 * (shifted unsigned: defined for negative c). */
#define F_STEP(c) ((int32_t)(uint32_t)((uint32_t)(int32_t)(c) << 1) + 1)
#endif

#define HOLD_STEPS(level) \
    ((uint16_t)((uint8_t)ramp_hold[(uint8_t)(level)] * (uint8_t)SETTING(SET_ACCEL)))  /* MUL AB */

/* Steps to the braking point while cruising (st_seg.steps is not kept up
 * meanwhile), n >= 1, as n = 256 * st_cruise_hi + st_cruise_lo with
 * st_cruise_lo in 1..256 (256 stored as 0): counting down is one `djnz`
 * per step. */
#define CRUISE_SET(n) (st_cruise_hi = (uint8_t)((uint16_t)((n) - 1) >> 8), st_cruise_lo = (uint8_t)(n))
#define CRUISE_LEFT() (((uint16_t)st_cruise_hi << 8) + (uint8_t)(st_cruise_lo - 1) + 1)

void stepper_init(void)
{
    pos_x = 0;
    pos_y = 0;
#ifdef ZAXIS
    pos_z = 0;
#endif
    st_port = HAL_PORT_IDLE;
#ifdef DRIVE_PHASE
    st_phase_y = PHASE_START;
    HAL_PORT2_OUT(PHASE_START);
#endif
    st_hold = 0;
    st_underruns = 0;
    stepper_abort();
    HAL_PORT_OUT(st_port);
}

IDATA int32_t pos_copy[2];

/* 1 if the four bytes at live differ from those at copy.  Byte by byte
 * through pointers: written as int32_t comparisons, SDCC takes the copy
 * for the pos_x it was just read from and compares pos_x with itself. */
static uint8_t moved(IDATA uint8_t *copy, volatile FAST uint8_t *live)
{
    uint8_t k = 4;
    do {
        if (*copy++ != *live++) return 1;
    } while (--k);
    return 0;
}

void stepper_snapshot(void)
{
    do {
        pos_copy[0] = POS_READ(pos_x);
        pos_copy[1] = POS_READ(pos_y);
    } while (moved((IDATA uint8_t *)&pos_copy[0], (volatile FAST uint8_t *)&pos_x) ||
             moved((IDATA uint8_t *)&pos_copy[1], (volatile FAST uint8_t *)&pos_y));
}

void stepper_zero(void)
{
    HAL_CRITICAL_BEGIN();
    pos_x = 0;
    pos_y = 0;
#ifdef ZAXIS
    pos_z = 0;
#endif
    HAL_CRITICAL_END();
}

void stepper_abort(void)
{
    HAL_STEPPER_SLOW();
    st_load = 1;
    st_pulse_x = 0;
    st_pulse_y = 0;
    st_level = 0;
    st_running = 0;
    st_paused = 0;
}

void stepper_start(void)
{
#ifdef PANEL
    st_port &= (uint8_t)~(BIT_X_DIR | BIT_Y_DIR);   /* the limit check must not see the last move's directions */
#endif
    stepper_abort();
    st_level = RAMP_INDEX(0, SETTING(SET_SHAPE));   /* the shape's bit stays while it runs */
    st_below = 0;
    st_level_left = HOLD_STEPS(st_level);
    /* The first interrupt loads the first segment, which takes several
     * hundred cycles: let the second, which emits the first pulse, come
     * when it is done, so that the ramp starts on time. */
    st_period = HAL_PERIOD(1024);
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

#ifndef HAL_STEPPER_ISR_EXTERNAL
/* An arc enters quadrant st_seg.quadrant: its moves and its end. */
INLINE void arc_enter_quadrant(void)
{
    uint8_t turn = arc_turns[st_seg.quadrant];
#ifdef INTERP_DDA
    st_moves = arc_both[st_seg.quadrant];
#else
    st_moves = arc_moves[st_seg.quadrant];
#endif
    st_end_x0 = turn & 1;
    st_end_neg = (turn >> 1) & 1;
}

/* Copy the next queued segment into st_seg and prepare its interpolation.
 * Returns 0 when the queue is empty. */
INLINE uint8_t load_segment(void)
{
    XDATA uint8_t *src;
    FAST uint8_t *dst;
    uint8_t n, slot;
    uint16_t brake;                  /* hold steps of the levels up to the exit level (none for 0) */
    slot = q_tail;
    if (slot == q_head) {
        return 0;
    }
    src = (XDATA uint8_t *)&queue[slot];
    dst = (FAST uint8_t *)&st_seg;
    n = sizeof(segment_t);
    do {
        *dst++ = *src++;
    } while (--n);

    st_line = 0;
#ifdef ZAXIS
    st_zmove = 0;
#endif
    if (st_seg.kind == SEG_LINE) {
        st_line = 1;
#if defined(INTERP_DDA)
        st_cap = st_seg.c;
#elif defined(INTERP_COMPARE)
        /* The base axis is the longer one (steps = its count).  F starts
         * at 0, or at -1 along an axis: the other axis must never step. */
        st_ybase = st_seg.a != st_seg.steps;
        st_lf = (st_seg.a && st_seg.b) ? 0 : -1;
#else
        st_lf = 0;
        if (!st_seg.a) st_lf = -1;   /* a pure Y move must never take the F >= 0 branch */
#endif
#ifdef ZAXIS
        /* A Z move is a line along Y with c = 1 (planner_z). */
        if (st_seg.c) st_zmove = 1;
        st_port = (st_port & ~(BIT_X_DIR | BIT_Y_DIR | BIT_Z_DIR)) | st_seg.dirs;
#else
        st_port = (st_port & ~(BIT_X_DIR | BIT_Y_DIR)) | st_seg.dirs;
#endif
#ifdef FOLLOW
    } else if (st_seg.kind == SEG_FOLLOW) {
        /* At the ramp's start rate, the whole way: the sensors may stop
         * it at any step, and from that rate a stop needs no braking. */
        st_level = RAMP_START(st_level);
        st_below = 0;
        st_level_left = HOLD_STEPS(st_level);
        follow_next = FOLLOW_BEGIN;
#endif
    } else if (st_seg.kind >= SEG_PEN) {
        if (st_seg.kind == SEG_PEN) {
            st_port = (st_port & ~BIT_PEN) | st_seg.dirs;
        }
        st_seg.kind = SEG_DWELL;
        st_level = RAMP_START(st_level);
        st_below = 0;
        st_level_left = HOLD_STEPS(st_level);
    } else {
#if defined(INTERP_DDA)
        /* The capacity 2^n comes in the high nibble of dirs (planner.c). */
        n = st_seg.dirs >> 4;
        st_seg.dirs &= 0x0F;
        st_cap = 1;
        while (n--) {
            st_cap <<= 1;
        }
#else
        st_af = 0;
#endif
        arc_enter_quadrant();
    }
#ifdef INTERP_DDA
    st_jx = st_cap >> 1;             /* half a step: the DDA rounds */
    st_jy = st_jx;
#endif
    n = slot + 1;                    /* QUEUE_NEXT without its int arithmetic */
    if (n == QUEUE_SLOTS) n = 0;
    q_tail = n;
    brake = st_seg.exit_brake;
    if (RAMP_ABOVE_START(st_seg.exit) && n == q_head) {
        /* Nothing follows yet: plan to stop rather than run off the queue's end. */
        st_seg.exit = RAMP_START(st_seg.exit);
        brake = 0;                   /* as the planner's for level 0 */
        st_underruns++;
    }
    st_brake_at = st_below - brake + st_level_left;
#ifdef INTERP_COMPARE
    /* An arc's iterations in its final quadrant (only the braking distance
     * above needed exit_brake). */
    st_seg.exit_brake = queue_final[slot];
#endif
    st_cruising = 0;
    st_stale = 1;
    HAL_SEGMENT_STARTED(st_seg.seq);
    return 1;
}

#ifndef INTERP_DIAGONAL
/* The arc's next move (one-hot MV_*); in the final quadrant never pass the end. */
INLINE uint8_t arc_next_move(void)
{
    uint8_t mv, toward;
    mv = ((int8_t)(st_af >> 24) < 0) ? (uint8_t)(st_moves >> 4) : (uint8_t)(st_moves & 0x0F);
    if (!st_seg.crossings) {
        toward = st_seg.dirs;
        if (!(mv & toward)) {
            /* The other move of the quadrant, if it heads towards the end. */
            mv = (st_moves | (st_moves >> 4)) & toward;
            if (!mv) {
                /* The end lies just off the staircase: walk straight onto it, X first. */
                mv = toward & MV_X;
                if (!mv) mv = toward;
            }
        }
    }
    return mv;
}
#endif

/* The code is laid out for the common case, a line at cruise speed: it runs
 * straight through to the end with one test per condition.  What happens
 * once per segment or quadrant (cruise set-up, an arc's turn into the next
 * quadrant) sits after the end, so that the jumps around the steps stay
 * short. */
STEPPER_ISR
{
    uint8_t mv;
    int16_t c;
    uint16_t hold;

    HAL_TIMER_ADVANCE(st_period);
#ifdef PANEL
    /* A closed limit switch at the end the machine is heading for: no more
     * pulses.  Heading away from it is allowed, to back off after a reset. */
    if (HAL_LIMITS_CLOSED() & st_port & (BIT_X_DIR | BIT_Y_DIR)) {
        HAL_TIMER_HALT();
        rt_limit = 1;
        return;
    }
#endif
#if defined(DRIVE_PHASE)
    /* The next pattern of the sequence on the windings, both axes at once
     * if the interpolation says so. */
    if (st_pulse_x) {
#if BIT_X_DIR == PHASE_SPAN
        mv = st_port & (PHASE_BITS | BIT_X_DIR);   /* the direction bit is the table's half */
#else
        mv = st_port & PHASE_BITS;
        if (st_port & BIT_X_DIR) mv |= PHASE_SPAN;
#endif
        st_port = (st_port & (uint8_t)~PHASE_BITS) | phase_next[mv];
        HAL_PORT_OUT(st_port);
        if (st_port & BIT_X_DIR) pos_x--; else pos_x++;
    }
    if (st_pulse_y) {
        mv = st_phase_y;
        if (st_port & BIT_Y_DIR) mv |= PHASE_SPAN;
        mv = phase_next[mv];
        st_phase_y = mv;
        HAL_PORT2_OUT(mv);
        if (st_port & BIT_Y_DIR) pos_y--; else pos_y++;
    }
#elif defined(INTERP_DIAGONAL)
    if (st_pulse_x || st_pulse_y) {  /* one axis or both, pulses together */
        mv = st_port;
        if (st_pulse_x) mv |= BIT_X_STEP;
        if (st_pulse_y) mv |= BIT_Y_STEP;
        HAL_PORT_OUT(mv);
        if (st_pulse_x) {
            if (st_port & BIT_X_DIR) pos_x--; else pos_x++;
        }
        if (st_pulse_y) {
            if (st_port & BIT_Y_DIR) pos_y--; else pos_y++;
        }
        HAL_PORT_OUT(st_port);
    }
#elif defined(ZAXIS)
    if (st_pulse_x) {                /* one axis per step */
        HAL_PORT_OUT(st_port | BIT_X_STEP);
        if (st_port & BIT_X_DIR) pos_x--; else pos_x++;
        HAL_PORT_OUT(st_port);
    } else if (st_pulse_y) {
        if (st_zmove) {
            HAL_PORT_OUT(st_port | BIT_Z_STEP);
            if (st_port & BIT_Z_DIR) pos_z--; else pos_z++;
        } else {
            HAL_PORT_OUT(st_port | BIT_Y_STEP);
            if (st_port & BIT_Y_DIR) pos_y--; else pos_y++;
        }
        HAL_PORT_OUT(st_port);
    }
#else
    if (st_pulse_x) {                /* one axis per step */
        HAL_PORT_OUT(st_port | BIT_X_STEP);
        if (st_port & BIT_X_DIR) pos_x--; else pos_x++;
        HAL_PORT_OUT(st_port);
    } else if (st_pulse_y) {
        HAL_PORT_OUT(st_port | BIT_Y_STEP);
        if (st_port & BIT_Y_DIR) pos_y--; else pos_y++;
        HAL_PORT_OUT(st_port);
    }
#endif
    if (st_load) {
        goto load;
    }
run:
    if (HOLDING && !RAMP_ABOVE_START(st_level) && st_seg.kind != SEG_DWELL) {
        goto pause;                  /* (a dwell runs its time out) */
    }
    if (!st_line) {
        goto not_line;
    }
#if defined(INTERP_DDA)
    /* DDA: each iteration adds |dx| and |dy| to the integrators' remainders;
     * an axis steps when its remainder reaches the capacity 2^n, the power
     * of two above both counts.  After 2^n iterations (steps = st_cap) each
     * axis has stepped exactly its count: no correction needed. */
    st_pulse_x = 0;
    st_jx += st_seg.a;
    if (st_jx & st_cap) {
        st_jx ^= st_cap;
        st_pulse_x = 1;
    }
    st_pulse_y = 0;
    st_jy += st_seg.b;
    if (st_jy & st_cap) {
        st_jy ^= st_cap;
        st_pulse_y = 1;
    }
#elif defined(INTERP_COMPARE)
    /* Comparison-integration (seed 004, 5.3.3.2, table 5-3): the base axis
     * steps every time, the other with it when F >= 0; F sums the other
     * count per base step and takes off the base count per step of the
     * other. */
    if (st_ybase) {
        st_pulse_y = 1;
        st_pulse_x = 0;
        if ((int8_t)(st_lf >> 8) >= 0) {
            st_lf -= st_seg.b;
            st_pulse_x = 1;
        }
        st_lf += st_seg.a;
    } else {
        st_pulse_x = 1;
        st_pulse_y = 0;
        if ((int8_t)(st_lf >> 8) >= 0) {
            st_lf -= st_seg.a;
            st_pulse_y = 1;
        }
        st_lf += st_seg.b;
    }
#else
    if ((int8_t)(st_lf >> 8) >= 0) {
        st_pulse_x = 1;
        st_pulse_y = 0;
        st_lf -= st_seg.b;
    } else {
        st_pulse_x = 0;
        st_pulse_y = 1;
        st_lf += st_seg.a;
    }
#endif
    if (!st_cruising) {
        goto count;
    }
cruise_step:
    /* Cruising: the step count is kept as its distance to the braking point,
     * which is all there is to watch (and a feed hold). */
    if (--st_cruise_lo == 0) {
        if (st_cruise_hi == 0) {
            st_seg.steps = st_cruise_to;
            goto cruise_end;
        }
        st_cruise_hi--;
    }
    if (!HOLDING) {
        return;
    }
    st_seg.steps = st_cruise_to + CRUISE_LEFT();
cruise_end:
#ifdef INTERP_DIAGONAL
    if (st_seg.steps == 0 && !st_line) {
        st_seg.steps = 1;            /* an arc ends where its end point is, not by the count */
    }
#else
    if (st_seg.steps == 0 && !st_line && st_seg.crossings) {
        st_seg.steps = 1;            /* an arc's estimate runs out at its end, not before */
    }
#endif
    goto ramp;

not_line:
    if (st_seg.kind == SEG_DWELL) {     /* also a pen's settle time */
        st_period = HAL_PERIOD(DWELL_PERIOD);
        st_seg.steps--;
        goto done;
    }
#ifdef FOLLOW
    if (st_seg.kind == SEG_FOLLOW) {
        /* The main loop's answer (follow_service): a step, a stop, or
         * none yet, when this period passes without a pulse. */
        st_period = st_seg.cruise_period;
        st_pulse_x = 0;
        st_pulse_y = 0;
        mv = follow_next;
        if (mv >= FOLLOW_IDLE) {
            return;
        }
        follow_next = FOLLOW_WAIT;
        if (mv & 0x80) {
            follow_next = FOLLOW_IDLE;
            st_seg.steps = 0;
            goto done;
        }
        if (mv < FOLLOW_STEP_YP) {
            st_pulse_x = 1;
            st_port &= (uint8_t)~BIT_X_DIR;
            if (mv == FOLLOW_STEP_XN) st_port |= BIT_X_DIR;
        } else {
            st_pulse_y = 1;
            st_port &= (uint8_t)~BIT_Y_DIR;
            if (mv == FOLLOW_STEP_YN) st_port |= BIT_Y_DIR;
        }
        HAL_PORT_OUT(st_port);       /* direction set a whole period before its pulse */
        return;
    }
#endif
    /* Arc.  F = x^2 + y^2 - R^2 changes by 2c+1 when a coordinate c becomes
     * c+1, by -2c+1 when it becomes c-1 (point-by-point comparison and
     * comparison-integration; the DDA has no F). */
#ifdef INTERP_DIAGONAL
#ifdef INTERP_DDA
    mv = st_moves;                   /* the quadrant's X and Y moves */
#else
    mv = (st_moves | (st_moves >> 4)) & 0x0F;
#endif
    if (!st_seg.crossings) {
        /* Final quadrant: only moves towards the end.  Final correction:
         * with one axis left, or when neither move of the quadrant heads
         * towards the end (an end a fraction of a step off the curve),
         * walk straight onto it, X first. */
        mv &= st_seg.dirs;
        if (!mv || !(st_seg.dirs & MV_X) || !(st_seg.dirs & MV_Y)) {
            mv = (st_seg.dirs & MV_X) ? (st_seg.dirs & MV_X) : st_seg.dirs;
            goto arc_move;
        }
    }
#if defined(INTERP_DDA)
    /* DDA (seed 001 1.2, seed 004 5.3.2): X integrates |y|, Y integrates
     * |x|, with the capacity 2^n just above the radius.  Y adds x after
     * this iteration's X step: updated in turn rather than at once, the
     * staircase closes on itself instead of spiralling outwards. */
    c = st_seg.b;
    if (c < 0) c = -c;
    st_jx += c;
    if (st_jx & st_cap) {
        st_jx ^= st_cap;
    } else {
        mv &= (uint8_t)~MV_X;
    }
    c = st_seg.a;
    if (mv & MV_XN) c--;
    if (mv & MV_XP) c++;
    if (c < 0) c = -c;
    st_jy += c;
    if (st_jy & st_cap) {
        st_jy ^= st_cap;
    } else {
        mv &= (uint8_t)~MV_Y;
    }
arc_move:
    st_pulse_x = 0;
    st_pulse_y = 0;
    if (mv & MV_X) {
        st_pulse_x = 1;
        if (mv & MV_XN) {
            st_seg.a--;
            st_port |= BIT_X_DIR;
        } else {
            st_seg.a++;
            st_port &= (uint8_t)~BIT_X_DIR;
        }
    }
    if (mv & MV_Y) {
        st_pulse_y = 1;
        if (mv & MV_YN) {
            st_seg.b--;
            st_port |= BIT_Y_DIR;
        } else {
            st_seg.b++;
            st_port &= (uint8_t)~BIT_Y_DIR;
        }
    }
#else
    /* Comparison-integration (seed 004, 5.3.3.4): the base axis is the
     * faster one, X where |y| > |x| (the other move of the quadrant if the
     * base's is ruled out), and steps every time; the other axis steps with
     * it when F says so: towards the inside while F >= 0, outwards while
     * F < 0 - the move point-by-point comparison would make.  F is the
     * exact x^2 + y^2 - R^2 rather than the seed's rectangle sums. */
    c = st_seg.a;                    /* |x| - |y| */
    if (c < 0) c = -c;
    if (st_seg.b < 0) c += st_seg.b; else c -= st_seg.b;
    c = ((c < 0) ? !(mv & MV_X) : (mv & MV_Y)) ? MV_Y : MV_X;     /* the base */
    mv &= (uint8_t)c | (((int8_t)(st_af >> 24) < 0) ? (uint8_t)(st_moves >> 4) : (uint8_t)(st_moves & 0x0F));
arc_move:
    st_pulse_x = 0;
    st_pulse_y = 0;
arc_move_next:
    /* One move at a time, X first, each changing F. */
    if (mv & MV_X) {
        st_pulse_x = 1;
        if (mv & MV_XN) {
            c = -st_seg.a;
            st_seg.a--;
            st_port |= BIT_X_DIR;
        } else {
            c = st_seg.a;
            st_seg.a++;
            st_port &= (uint8_t)~BIT_X_DIR;
        }
        mv &= MV_Y;
    } else {
        st_pulse_y = 1;
        if (mv & MV_YN) {
            c = -st_seg.b;
            st_seg.b--;
            st_port |= BIT_Y_DIR;
        } else {
            c = st_seg.b;
            st_seg.b++;
            st_port &= (uint8_t)~BIT_Y_DIR;
        }
        mv = 0;
    }
    st_af += F_STEP(c);
    if (mv) {
        goto arc_move_next;
    }
#endif
#else
    mv = arc_next_move();
    if (mv & MV_X) {
        st_pulse_x = 1;
        st_pulse_y = 0;
        if (mv & MV_NEG) {
            c = st_seg.a - 1;
            st_seg.a = c;
            c = ~c;                  /* minus the coordinate before the move */
            st_port |= BIT_X_DIR;
        } else {
            c = st_seg.a;
            st_seg.a++;
            st_port &= (uint8_t)~BIT_X_DIR;
        }
    } else {
        st_pulse_x = 0;
        st_pulse_y = 1;
        if (mv & MV_NEG) {
            c = st_seg.b - 1;
            st_seg.b = c;
            c = ~c;                  /* minus the coordinate before the move */
            st_port |= BIT_Y_DIR;
        } else {
            c = st_seg.b;
            st_seg.b++;
            st_port &= (uint8_t)~BIT_Y_DIR;
        }
    }
    st_af += (int32_t)((uint32_t)(int32_t)c << 1 | 1);   /* 2c + 1 (2c is even): shifted unsigned, defined for negative c */
#endif
#ifndef DRIVE_PHASE
    HAL_PORT_OUT(st_port);           /* direction set a whole period before its pulse */
#endif
    if (st_seg.crossings) {
        /* Has the arc reached the half-axis that ends its quadrant?  Testing
         * the point, not the last move, keeps radius 1 right: its staircase
         * passes through the centre, which lies on every axis and ends no
         * quadrant. */
        if (st_end_x0) {
            if (st_seg.a != 0) goto in_quadrant;
            c = st_seg.b;
        } else {
            if (st_seg.b != 0) goto in_quadrant;
            c = st_seg.a;
        }
        if (c != 0 && (c < 0) == st_end_neg) {
            goto turn;
        }
    in_quadrant:
        if (st_cruising) {
            goto cruise_step;
        }
        if (st_seg.steps == 1) {
            goto ramp;               /* an estimate: the count runs out at the end, not before */
        }
    } else {
#ifdef INTERP_DIAGONAL
        /* An axis that reached its end coordinate moves no more; the arc
         * ends with both, whatever the count says. */
        if (st_seg.a == st_seg.c) st_seg.dirs &= (uint8_t)~MV_X;
        if (st_seg.b == st_seg.d) st_seg.dirs &= (uint8_t)~MV_Y;
        if (!st_seg.dirs) {
            st_load = 1;
            return;
        }
        if (st_cruising) {
            goto cruise_step;
        }
        if (st_seg.steps == 1) {
            goto ramp;
        }
#else
        /* An axis that reached its end coordinate moves no more. */
        if (st_pulse_x) {
            if (st_seg.a == st_seg.c) st_seg.dirs &= (uint8_t)~MV_X;
        } else if (st_seg.b == st_seg.d) {
            st_seg.dirs &= (uint8_t)~MV_Y;
        }
        if (st_cruising) {
            goto cruise_step;
        }
#endif
    }
count:
    st_seg.steps--;
ramp:
    /* Brake to the exit level in time, else climb to the cruise level. */
    st_cruising = 0;
    mv = 0;                          /* brake (or slow down for a feed hold) */
    if (!(RAMP_ABOVE_START(st_level) && (HOLDING || st_level > st_seg.cruise ||
                       (st_level > st_seg.exit && st_seg.steps <= st_brake_at)))) {
        if (st_level >= st_seg.cruise || HOLDING) {
            goto cruise;
        }
        mv = 1;                      /* climb towards the cruise level */
    }
    st_brake_at--;
    if (--st_level_left == 0) {
        if (!mv) {
            st_level -= RAMP_STEP;
            st_level_left = HOLD_STEPS(st_level);
            st_below -= st_level_left;
            st_stale = 1;
        } else {
            /* Here st_brake_at counts the levels between this one and the
             * exit: the steps braking needs once this level is done (at the
             * exit level itself it is minus that level's hold, so the sums
             * are taken modulo 2^16 as the 8051 does). */
            st_level_left = HOLD_STEPS(st_level);
            hold = HOLD_STEPS(st_level + RAMP_STEP);
            if (st_level < st_seg.exit ||
                st_seg.steps >= (uint16_t)(st_brake_at + st_level_left + hold)) {
                /* Room to brake from the next level too: climb. */
                st_brake_at += st_level_left;
                st_below += st_level_left;
                st_level += RAMP_STEP;
                st_level_left = hold;
                st_stale = 1;
            } else if (st_seg.steps <= st_brake_at) {
                st_level_left = 1;           /* no step to spare: brake at once */
            } else {
                hold = st_seg.steps - st_brake_at;
                if (hold < st_level_left) {
                    st_level_left = hold;    /* stay only while braking still arrives */
                }
            }
            st_brake_at += st_level_left;
        }
    }
    if (st_stale) {
        st_stale = 0;
        mv = st_level;
        c = RAMP_HI_SHORT;
        if (mv < RAMP_HI_LEVELS) c = ramp_period_hi[mv];
        st_period = RAMP_PERIOD(c, ramp_period_lo[mv]);
    }
done:
    if (st_seg.steps == 0) {
        st_load = 1;
    }
    return;

load:
    st_pulse_x = 0;
    st_pulse_y = 0;
    if (!load_segment()) {
        HAL_TIMER_HALT();
        st_level = 0;
        st_running = 0;
        return;
    }
    HAL_PORT_OUT(st_port);           /* directions and pen settle a whole period before the pulse */
    if (st_seg.steps == 0) {
        st_period = HAL_PERIOD(64);  /* empty segment: look again shortly */
        return;
    }
    st_load = 0;
    goto run;

pause:
    /* Feed hold has slowed to the start rate: stop here, resume later. */
    HAL_TIMER_HALT();
    st_paused = 1;
    st_pulse_x = 0;
    st_pulse_y = 0;
    return;

cruise:
    /* Cruise at the commanded feed until the braking point (never, if
     * the exit level is not below this one). */
    st_period = st_seg.cruise_period;
    st_stale = 1;
    st_cruise_to = 0;
    if (st_level > st_seg.exit) st_cruise_to = st_brake_at;
    hold = st_seg.steps - st_cruise_to;
    CRUISE_SET(hold);
    st_cruising = 1;
    goto done;

turn:
    /* The arc has crossed into the next quadrant. */
#ifdef INTERP_DDA
    /* The axis along the half-axis turns round: its remainder, the
     * part of a step it has gone past its position, now lies the
     * other way. */
    c = st_cap - 1;
    if (st_end_x0) st_jy ^= c; else st_jx ^= c;
#endif
    st_seg.quadrant = arc_turns[st_seg.quadrant] >> 4;
    arc_enter_quadrant();
    if (--st_seg.crossings) {
        goto in_quadrant;
    }
    /* Final quadrant: the remaining count is now exact, and the
     * moves towards the end are known (same quadrant: the
     * differences do not overflow). */
    mv = 0;
    c = st_seg.c - st_seg.a;
    if (c < 0) {
        mv = MV_XN;
        c = -c;
    } else if (c) {
        mv = MV_XP;
    }
    hold = (uint16_t)c;
    c = st_seg.d - st_seg.b;
    if (c < 0) {
        mv |= MV_YN;
        c = -c;
    } else if (c) {
        mv |= MV_YP;
    }
    st_seg.steps = hold + (uint16_t)c;
    st_seg.dirs = mv;
#if defined(INTERP_COMPARE)
    /* The iterations to the end, as the planner counted them
     * (none if the end is here). */
    if (st_seg.dirs) {
        st_seg.steps = st_seg.exit_brake;
    }
#elif defined(INTERP_DDA)
    /* Steps to iterations, at least 1 unless the end is here
     * (then none).  2^n / R is at least 4/3 when the radius
     * (the coordinate along the half-axis) is under 3/4 of the
     * capacity: then the steps themselves are a lower bound.
     * (Not more: the final correction walks one step per
     * iteration.) */
    c = st_seg.a | st_seg.b;
    if (c < 0) c = -c;
    if ((uint16_t)c >= st_cap - (st_cap >> 2)) {
        st_seg.steps = ARC_ITERATIONS(st_seg.steps);
    }
    if (!st_seg.steps && st_seg.dirs) {
        st_seg.steps = 1;
    }
#endif
    goto ramp;
}
#endif
