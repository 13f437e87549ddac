/* core_api.c - the firmware core as a host shared library, for tests and the
 * mock board.  The caller plays the hardware: it feeds received bytes, calls
 * the main loop, and fires the step interrupt when the timer says so. */
#include <string.h>
#include "../../core/config.h"
#include "../../core/hal.h"
#include "../../core/stepper.h"
#include "../../core/planner.h"
#include "../../core/serial.h"
#include "../../core/protocol.h"
#include "../../core/ramp.h"
#include "../../core/panel.h"
#include "../../core/follow.h"

uint16_t host_period;
uint8_t host_timer_on;
uint8_t host_port;
uint8_t host_port2;
uint8_t host_key = 0xFF, host_limits, host_estop;
uint8_t host_seg[8];
uint8_t host_sensors, host_follow_key;

/* An HD44780 as far as the firmware uses it: set-address commands and data
 * bytes into two 16-character lines (other commands: clear on 0x01). */
static char lcd_text[2][17];
static uint8_t lcd_addr;

void host_lcd_write(uint8_t b, uint8_t rs)
{
    if (!rs) {
        if (b & 0x80) {
            lcd_addr = b & 0x7F;
        } else if (b == 0x01) {
            memset(lcd_text[0], ' ', 16);
            memset(lcd_text[1], ' ', 16);
            lcd_addr = 0;
        }
        return;
    }
    if (lcd_addr < 16) lcd_text[0][lcd_addr] = (char)b;
    else if (lcd_addr >= 0x40 && lcd_addr < 0x50) lcd_text[1][lcd_addr - 0x40] = (char)b;
    lcd_addr++;
}

#define TX_CAP 8192
static uint8_t tx[TX_CAP];
static uint32_t tx_len;

#define SEQ_LOG_CAP 65536
static uint16_t seq_log[SEQ_LOG_CAP];
static uint32_t seq_log_len;

void hal_putc(uint8_t c)
{
    if (tx_len < TX_CAP) {
        tx[tx_len++] = c;
    }
}

void host_segment_started(uint16_t seq)
{
    if (seq_log_len < SEQ_LOG_CAP) {
        seq_log[seq_log_len++] = seq;
    }
}

/* Power-on: everything as the 8051's start-up code leaves it, then main()'s set-up. */
void core_reset(void)
{
    host_period = 0;
    host_timer_on = 0;
    host_port = 0;
    host_port2 = 0;
    tx_len = 0;
    seq_log_len = 0;
    q_head = q_tail = 0;
    rx_head = rx_tail = rx_flush_to = 0;
    rx_overflow = 0;
    rx_between_lines = 1;
    rx_arm_a = rx_arm_b = 0;
    rt_status = rt_resume = rt_estop = rt_reset = 0;
    setting[SET_ACCEL] = 1;
    setting[SET_SHAPE] = RAMP_TRAPEZOID;
    setting[SET_FEED] = 2000;
    setting[SET_PEN] = 150;
#ifdef FOLLOW
    follow_next = FOLLOW_IDLE;
    follow_state = FOLLOW_STATE_NONE;
    memset(&follow_args, 0, sizeof follow_args);   /* the chip's startup clears its XRAM */
#endif
    host_sensors = host_follow_key = 0;
    stepper_init();
#ifdef PANEL
    host_key = 0xFF;
    host_limits = host_estop = 0;
    rt_limit = rt_star = 0;
    memset(lcd_text[0], ' ', 16);
    memset(lcd_text[1], ' ', 16);
    lcd_text[0][16] = lcd_text[1][16] = 0;
    memset(host_seg, 0, sizeof host_seg);
    lcd_addr = 0;
    panel_init();
#endif
    protocol_init();
}

#ifdef PANEL
/* The panel's 1 ms tick, the panel's hardware and what it shows. */
void core_panel_tick(void) { panel_tick(); }
void core_set_key(int key) { host_key = (uint8_t)key; }
void core_set_limits(int bits) { host_limits = (uint8_t)bits; }
/* The switches by axis, whatever pins this build's direction bits are on: closed at the -X, -Y end. */
void core_set_switches(int x_closed, int y_closed)
{
    host_limits = (uint8_t)((x_closed ? BIT_X_DIR : 0) | (y_closed ? BIT_Y_DIR : 0));
}
void core_set_estop(int on) { host_estop = (uint8_t)on; }
const char *core_lcd_line(int n) { return lcd_text[n & 1]; }
int core_segment(int digit) { return host_seg[digit & 7]; }
#endif

void core_rx(const uint8_t *data, uint32_t n)
{
    uint32_t k;
    for (k = 0; k < n; k++) {
        uint8_t c = data[k];
        SERIAL_RX_BYTE(c);
    }
}

uint32_t core_rx_free(void) { return RX_SIZE - (uint8_t)(rx_head - rx_tail); }

void core_poll(void) { protocol_poll(); }

/* Fire the step interrupt once; 1 if it emitted a step. */
int core_tick(void)
{
    int32_t x = pos_x, y = pos_y;
    stepper_isr();
    return (pos_x != x || pos_y != y) ? 1 : 0;
}

int core_timer_on(void) { return host_timer_on; }
unsigned core_period(void) { return host_period; }
int32_t core_pos_x(void) { return pos_x; }
int32_t core_pos_y(void) { return pos_y; }
#ifdef ZAXIS
int32_t core_pos_z(void) { return pos_z; }
#endif
int core_pen(void) { return (host_port & BIT_PEN) ? 1 : 0; }
int core_port(void) { return host_port; }
int core_port2(void) { return host_port2; }

/* The build options: interpolation 0 point-by-point comparison, 1 DDA,
 * 2 comparison-integration; drive 0 step/direction, 1 three-phase single,
 * 2 three-phase double excitation, 3 two-phase unipolar. */
#if defined(INTERP_DDA)
int core_interp(void) { return 1; }
#elif defined(INTERP_COMPARE)
int core_interp(void) { return 2; }
#else
int core_interp(void) { return 0; }
#endif
#if defined(DRIVE_PHASE3)
int core_drive(void) { return 1; }
#elif defined(DRIVE_PHASE3D)
int core_drive(void) { return 2; }
#elif defined(DRIVE_UNIPOLAR)
int core_drive(void) { return 3; }
#else
int core_drive(void) { return 0; }
#endif
/* The fastest feeds the image of these options accepts for a line and an
 * arc (core/ramp.h): its step interrupt's, which the host build only
 * reports. */
unsigned core_line_top(void) { return LINE_TOP; }
unsigned core_arc_top(void) { return ARC_TOP; }
int core_running(void) { return st_running; }
unsigned core_queue_free(void) { return QUEUE_FREE(); }
unsigned core_underruns(void) { return st_underruns; }
int core_alarm(void) { return alarm_code; }
void core_set_alarm(int code) { protocol_alarm((uint8_t)code); }

uint32_t core_tx_read(uint8_t *out, uint32_t cap)
{
    uint32_t n = tx_len < cap ? tx_len : cap;
    memcpy(out, tx, n);
    memmove(tx, tx + n, tx_len - n);
    tx_len -= n;
    return n;
}

/* Takes the numbers logged since the last call: the host drains the log as it goes, so a job of
 * any length is logged whole as long as no more than SEQ_LOG_CAP commands start between calls. */
uint32_t core_seq_log_take(uint16_t *out, uint32_t cap)
{
    uint32_t n = seq_log_len < cap ? seq_log_len : cap;
    memcpy(out, seq_log, n * sizeof(uint16_t));
    memmove(seq_log, seq_log + n, (seq_log_len - n) * sizeof(uint16_t));
    seq_log_len -= n;
    return n;
}

/* Direct planner access for exhaustive interpolation tests. */
int core_plan_line(int dx, int dy, unsigned feed, unsigned exit_rate)
{
    plan_arg[0] = (uint16_t)dx;
    plan_arg[1] = (uint16_t)dy;
    plan_arg[PLAN_FEED] = (uint16_t)feed;
    plan_arg[PLAN_EXIT] = (uint16_t)exit_rate;
    plan_seq = 0;
    return planner_line();
}

int core_plan_arc(int dx, int dy, int i, int j, int cw, unsigned feed, unsigned exit_rate)
{
    plan_arg[0] = (uint16_t)dx;
    plan_arg[1] = (uint16_t)dy;
    plan_arg[2] = (uint16_t)i;
    plan_arg[3] = (uint16_t)j;
    plan_arg[PLAN_FEED] = (uint16_t)feed;
    plan_arg[PLAN_EXIT] = (uint16_t)exit_rate;
    plan_seq = 0;
    return planner_arc((uint8_t)cw);
}

/* Run queued motion to the end in simulated time, recording every step.
 * out receives (dx, dy, period) triples per step: the move of each axis in
 * -1/0/+1 and the cycles since the previous step.  Returns the step count,
 * or -1 if cap was too small. */
int32_t core_run_steps(int32_t *out, int32_t cap)
{
    int32_t n = 0;
    uint32_t since = 0;
    if (!st_running) {
        stepper_start();
    }
    while (host_timer_on) {
        int32_t x = pos_x, y = pos_y;
        since += host_period;
        stepper_isr();
        if (pos_x != x || pos_y != y) {
            if (n >= cap) {
                return -1;
            }
            out[3 * n] = pos_x - x;
            out[3 * n + 1] = pos_y - y;
            out[3 * n + 2] = (int32_t)since;
            since = 0;
            n++;
        }
    }
    return n;
}

/* Line following, driven by the caller's virtual sheet: core_follow_tick
 * takes the sensor bits of one step period and answers as follow_tick. */
void core_follow_start(int heading, int lost_steps, int max_steps, int home_steps)
{
    follow_args.heading = (uint8_t)heading;
    follow_args.lost_steps = (uint16_t)lost_steps;
    follow_args.max_steps = (uint16_t)max_steps;
    follow_args.home_steps = (uint16_t)home_steps;
    follow_start();
}

int core_follow_tick(int black) { return follow_tick((uint8_t)black); }

#ifdef FOLLOW
/* The FOLLOW image's sensors, and its main loop's part in an F: the mock
 * board sets the sensors where its pen is and answers the step interrupt's
 * next step before each tick, as the chip's main loop does between them. */
void core_set_sensors(int black) { host_sensors = (uint8_t)(black & FOLLOW_SENSOR_MASK); }
void core_set_follow_key(int pressed) { host_follow_key = (uint8_t)(pressed != 0); }
void core_follow_service(void) { follow_service(); }
int core_follow_mailbox(void) { return follow_next; }
#endif
