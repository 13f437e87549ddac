/* panel.c - see panel.h.
 *
 * A key acts once per press, when it has read the same for DEBOUNCE ticks.
 * Motion keys act only while the machine stands still (one press, one move);
 * the reset and pause keys act always, except while a number is typed.  Numbers are
 * typed on the keys of seed 000 figure 3.3 (digit = column * 4 + row, so the
 * reset key is the 0): they shift in from the right of the 7-segment
 * display, and after four digits, or at any other key, the number is
 * taken. */
#include "panel.h"
#include "planner.h"
#include "stepper.h"
#include "serial.h"
#include "protocol.h"

#ifdef PANEL

#define DEBOUNCE   10           /* ms a key must read the same */
#define JOG_STEPS  800          /* one jog press: 10 mm at 80 steps/mm */
/* The jog feed in units of JOG_UNIT steps/s, 1..JOG_MAX (250..8000 steps/s):
 * the faster and slower keys double and halve it. */
#define JOG_UNIT   250
#define JOG_MAX    32
#define JOG_FEED() ((uint8_t)jog * (uint8_t)JOG_UNIT)   /* mul ab: 8 x 8 bits */

/* What each key does (seed 000, figure 3.2): a jog in the MV_* directions
 * of the low nibble, a figure, or one of the others. */
#define A_JOG    0x10
#define A_FIGURE 0x20
#define A_NONE   0
#define A_RESET  1
#define A_CIRCLE 2
#define A_FASTER 3
#define A_SLOWER 4
#define A_PAUSE  5
static const ROM uint8_t key_action[16] = {
    A_RESET,              A_JOG | MV_XP, A_FIGURE | FIG_CONE,    A_CIRCLE,
    A_JOG | MV_XP | MV_YP, A_JOG | MV_XN, A_FIGURE | FIG_DIAMOND, A_FIGURE | FIG_STAR,
    A_FASTER,             A_JOG | MV_YP, A_NONE,                 A_FIGURE | FIG_CAR,
    A_SLOWER,             A_JOG | MV_YN, A_PAUSE,                A_FIGURE | FIG_CAR_REV,
};
/* The prompts, one string after another; panel_prompt is the offset of
 * its own.  SDCC would store a string again for each sizeof of it, so the
 * offsets are written out, and the host build checks them. */
#define T_DIAMOND  "Diamond"
#define T_STAR     "Star"
#define T_CONE     "Cone"
#define T_CAR      "Car"
#define T_CAR_REV  "Car reversed"
#define T_CENTRE_X "Centre X?"
#define T_CENTRE_Y "Centre Y?"
#define T_RADIUS   "Radius?"
#define T_READY    "Ready"
#define T_JOG      "Jog"
#define T_CIRCLE   "Circle"
#define T_RANGE    "Out of range"
#define T_PAUSED   "Paused"
static const ROM char prompts[] =
    T_DIAMOND "\0" T_STAR "\0" T_CONE "\0" T_CAR "\0" T_CAR_REV "\0"
    T_CENTRE_X "\0" T_CENTRE_Y "\0" T_RADIUS "\0"
    T_READY "\0" T_JOG "\0" T_CIRCLE "\0" T_RANGE "\0" T_PAUSED;
#define P_DIAMOND  0
#define P_STAR     8
#define P_CONE     13
#define P_CAR      18
#define P_CAR_REV  22
#define P_CENTRE_X 35
#define P_CENTRE_Y 45
#define P_RADIUS   55
#define P_READY    63
#define P_JOG      69
#define P_CIRCLE   73
#define P_RANGE    80
#define P_PAUSED   93
#define P_FIELD    10       /* the three numbers' prompts: P_CENTRE_X + field * P_FIELD */
/* A number is being typed while its prompt shows: the prompt is the state
 * of the entry (no other prompt lies between the first and the last). */
#define TYPING() ((uint8_t)(panel_prompt - P_CENTRE_X) <= (uint8_t)(P_RADIUS - P_CENTRE_X))
#ifndef __SDCC
#define PROMPT_AFTER(p, t, q) typedef char prompt_##q##_offset[(p) + sizeof t == (q) ? 1 : -1]
PROMPT_AFTER(P_DIAMOND, T_DIAMOND, P_STAR);
PROMPT_AFTER(P_STAR, T_STAR, P_CONE);
PROMPT_AFTER(P_CONE, T_CONE, P_CAR);
PROMPT_AFTER(P_CAR, T_CAR, P_CAR_REV);
PROMPT_AFTER(P_CAR_REV, T_CAR_REV, P_CENTRE_X);
PROMPT_AFTER(P_CENTRE_X, T_CENTRE_X, P_CENTRE_Y);
PROMPT_AFTER(P_CENTRE_Y, T_CENTRE_Y, P_RADIUS);
PROMPT_AFTER(P_RADIUS, T_RADIUS, P_READY);
PROMPT_AFTER(P_READY, T_READY, P_JOG);
PROMPT_AFTER(P_JOG, T_JOG, P_CIRCLE);
PROMPT_AFTER(P_CIRCLE, T_CIRCLE, P_RANGE);
PROMPT_AFTER(P_RANGE, T_RANGE, P_PAUSED);
typedef char no_other_prompt_among_the_fields[P_CAR_REV < P_CENTRE_X && P_RADIUS < P_READY ? 1 : -1];
typedef char prompts_of_the_fields_are_evenly_spaced[
    P_CENTRE_Y - P_CENTRE_X == P_FIELD && P_RADIUS - P_CENTRE_Y == P_FIELD ? 1 : -1];
#endif
static const ROM uint8_t figure_prompt[FIGURES] = {P_DIAMOND, P_STAR, P_CONE, P_CAR, P_CAR_REV};  /* FIG_* */

XDATA uint8_t panel_segments[4];
FAST uint8_t panel_prompt;
volatile FLAG rt_star;
static FLAG panel_moving;               /* a key started motion: "Ready" once it ends */

static XDATA uint8_t key_last, key_count;  /* read once a millisecond: not worth direct RAM */
static FAST uint8_t jog;                /* the jog feed / JOG_UNIT */
static FAST uint16_t entry;             /* the number typed */
static XDATA uint8_t entry_n;           /* digits typed */
static XDATA uint16_t circle[2];        /* the centre typed */

static void to_menu(void)
{
    panel_prompt = P_READY;
    panel_moving = 0;
    protocol_segments(JOG_FEED());
}

void panel_stop(void)
{
    fig_next = 0;
    to_menu();
}

/* External RAM is not cleared at power-up: what needs a start value gets it. */
void panel_init(void)
{
    key_last = K_NONE;
    jog = 2000 / JOG_UNIT;
    DISPLAY_INIT();
    panel_stop();
}

static uint8_t motion_idle(void)
{
    if (planner_busy() || FIGURE_PLAYING() || alarm_code) return 0;
    return 1;
}

/* plan_arg[k], a target coordinate, less the pen's coordinate k: 0 if
 * that is beyond a move's reach.  16-bit arithmetic on the position's
 * halves: the difference fits a move when the high half plus the borrow is
 * its sign.  The target comes in plan_arg, not as a parameter: a byte less
 * of the internal RAM that SDCC overlays for leaf functions. */
static uint8_t to_target(uint8_t k)
{
    IDATA uint16_t *d = &plan_arg[k];
    uint16_t lo = (uint16_t)pos_copy[k];
    uint16_t hi = (uint16_t)((uint32_t)pos_copy[k] >> 16);
    if (*d < lo) hi++;
    *d -= lo;
    return hi == (*d >> 15);
}

/* The circle of the typed centre and radius (steps from the origin): the
 * pen up to its rightmost point, one full counter-clockwise arc. */
static void circle_start(void)
{
    IDATA uint16_t *p;
    stepper_snapshot();
    plan_arg[0] = circle[0] + entry;
    plan_arg[1] = circle[1];
    if (!entry || !to_target(0) || !to_target(1)) {
        panel_prompt = P_RANGE;
        return;
    }
    figure_move(FC_LINE | FC_UP);
    p = plan_arg;
    do {
        *p++ = 0;
    } while (p != &plan_arg[4]);
    plan_arg[2] = 0 - entry;
    figure_move(FC_CCW | FC_DOWN);
    planner_pen(0);
    panel_prompt = P_CIRCLE;
    panel_moving = 1;
}

/* The next number of the circle, from 0000. */
static void new_number(void)
{
    entry = 0;
    entry_n = 0;
    protocol_segments(0);
}

/* A key while a number is typed: a digit shifts in, any other key (or a
 * fifth digit) takes the number. */
static void key_typed(uint8_t k)
{
    /* column * 4 + row: bits 2..5 of the key code written twice, 0xrc */
    k = (uint8_t)((uint8_t)(k * (uint8_t)0x11) >> 2) & 0x0F;
    if (k <= 9 && entry_n < 4) {
        /* entry * 10 + the digit, by two 8 x 8 bit products (mul ab) */
        entry = (uint16_t)((uint8_t)entry * (uint8_t)10)
                + ((uint16_t)(uint8_t)((uint8_t)(entry >> 8) * (uint8_t)10) << 8) + k;
        entry_n++;
        protocol_segments(entry);
        return;
    }
    if (panel_prompt == P_RADIUS) {
        to_menu();
        circle_start();
        return;
    }
    if (panel_prompt == P_CENTRE_X) {
        circle[0] = entry;                          /* the centre: X, then Y */
    } else {
        circle[1] = entry;
    }
    panel_prompt += P_FIELD;
    new_number();
}

static void key_pressed(uint8_t k)
{
    IDATA uint16_t *p;
    uint8_t a;
    if (TYPING()) {
        key_typed(k);
        return;
    }
    a = key_action[k];
    if (a == A_RESET) {
        if (motion_idle()) {              /* standing still: clear the coordinates */
            stepper_zero();
        }
        RT_STOP(rt_reset);                /* moving: stop at once, as Ctrl-X does */
        return;
    }
    if (a == A_PAUSE) {
        if (HOLDING) {
            stepper_resume();             /* paused: on from where it stopped */
        } else if (!motion_idle() && !alarm_code) {
            STEPPER_HOLD();               /* moving: brake along the path and stop, as `!` does */
        }
        return;
    }
    if (!motion_idle()) return;
    if (a & A_JOG) {
        p = plan_arg;                     /* X, then Y: MV_XP, MV_XN, then MV_YP, MV_YN */
        do {
            *p = 0;
            if (a & MV_XP) *p = JOG_STEPS;
            if (a & MV_XN) *p = (uint16_t)-JOG_STEPS;
            p++;
            a >>= 2;
        } while (p != &plan_arg[2]);
        plan_arg[PLAN_FEED] = JOG_FEED();
        plan_arg[PLAN_EXIT] = 0;
        planner_line();
        panel_prompt = P_JOG;
        panel_moving = 1;
        return;
    }
    if (a & A_FIGURE) {
        a &= 0x0F;
        panel_prompt = figure_prompt[a];
        panel_moving = 1;
        FIGURE_START(a);
        return;
    }
    if (a == A_FASTER && jog < JOG_MAX) jog <<= 1;
    if (a == A_SLOWER && jog > 1) jog >>= 1;
    if (a != A_CIRCLE) {
        to_menu();
        return;
    }
    panel_prompt = P_CENTRE_X;
    new_number();
}

void panel_tick(void)
{
    uint8_t k = HAL_KEY_SCAN();
    if (k != key_last) {
        key_last = k;
        key_count = DEBOUNCE;             /* counts down the readings left */
    } else if (key_count && !--key_count && k < KEYS) {
        key_pressed(k);
    }
    if (HAL_ESTOP_ACTIVE() && alarm_code != ALARM_ESTOP && !rt_estop) {
        RT_STOP(rt_estop);                /* still held: the alarm comes back after a reset */
    }
    if (rt_star) {
        rt_star = 0;
        if (!TYPING()) {
            key_pressed(K_STAR);          /* as the star key, but never as a digit */
        }
    }
    figure_poll();
    if (panel_moving && motion_idle()) {
        to_menu();
    }
    display_tick();
}

const ROM char *panel_text(void)
{
    if (alarm_code) return alarm_text();
    if (HOLDING) return &prompts[P_PAUSED];
    return &prompts[panel_prompt];
}

#endif
