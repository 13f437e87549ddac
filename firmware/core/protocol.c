/* protocol.c - see protocol.h and firmware/PROTOCOL.md.
 *
 * A line is parsed only once it is complete, and a command changes nothing
 * unless every argument parsed: a bad line never moves the machine.  Lines
 * that carry a sequence number (N...) must also carry a valid checksum; they
 * are executed exactly once, in order: a repeat of an executed number is
 * acknowledged again without running, a gap or a damaged line asks the host
 * to resend from the expected number. */
#include "protocol.h"
#include "planner.h"
#include "stepper.h"
#include "serial.h"
#include "ramp.h"

uint8_t alarm_code;

static IDATA char line[LINE_MAX + 1];
static uint8_t line_len;
static uint8_t line_xor;          /* XOR of the bytes before '*' */
static uint8_t line_star;         /* index of '*' + 1, 0 if none */
static uint8_t line_long;         /* the line overflowed LINE_MAX */
static uint16_t expected_seq;     /* next sequence number to execute */
static uint8_t resend_asked;      /* an rs is outstanding: drop later lines quietly */

static uint8_t cur;               /* parse cursor into line[] */
static IDATA uint16_t arg_mag[6];  /* magnitudes of the arguments */
static uint8_t arg_neg;           /* bit k set: argument k is negative */
static uint8_t nargs;

static void put_str(const char *s)
{
    while (*s) {
        hal_putc((uint8_t)*s++);
    }
}

static RAMP_ROM uint32_t powers[] = {1000000000UL, 100000000UL, 10000000UL, 1000000UL,
                                     100000UL, 10000UL, 1000UL, 100UL, 10UL, 1UL};

/* Decimal without division: the 8051 has no 32-bit divide. */
static void put_i32(int32_t sv)
{
    uint32_t v;
    uint8_t k, d, started = 0;
    if (sv < 0) {
        hal_putc('-');
        v = (uint32_t)(-sv);
    } else {
        v = (uint32_t)sv;
    }
    for (k = 0; k < 10; k++) {
        d = 0;
        while (v >= powers[k]) {
            v -= powers[k];
            d++;
        }
        if (d || started || k == 9) {
            hal_putc((uint8_t)('0' + d));
            started = 1;
        }
    }
}

static void put_field(char tag, int32_t v)
{
    hal_putc(' ');
    hal_putc((uint8_t)tag);
    put_i32(v);
}

static void put_eol(void)
{
    hal_putc('\r');
    hal_putc('\n');
}

void protocol_init(void)
{
    line_len = 0;
    line_xor = 0;
    line_star = 0;
    line_long = 0;
    expected_seq = 0;
    resend_asked = 0;
    alarm_code = 0;
    put_str(FW_NAME " " FW_VERSION " ready");
    put_eol();
}

static void report_status(void)
{
    int32_t x, y;
    HAL_CRITICAL_BEGIN();
    x = pos_x;
    y = pos_y;
    HAL_CRITICAL_END();
    hal_putc('<');
    put_str(alarm_code ? "Alarm" : st_hold ? "Hold" : st_running ? "Run" : "Idle");
    put_field('X', x);
    put_field('Y', y);
    put_field('Q', QUEUE_FREE());
    put_field('N', expected_seq);
    put_field('S', st_seq);
    put_field('P', (st_port & BIT_PEN) ? 1 : 0);
    put_field('U', st_underruns);
    put_field('A', alarm_code);
    hal_putc('>');
    put_eol();
}

void protocol_alarm(uint8_t code)
{
    HAL_TIMER_HALT();
    stepper_abort();
    planner_flush();
    st_hold = 0;
    alarm_code = code;
    put_str(code == ALARM_ESTOP ? "[alarm estop]" : "[alarm limit]");
    put_eol();
}

static const char *error_text(uint8_t code)
{
    switch (code) {
    case E_UNKNOWN:   return "unknown command";
    case E_CHECKSUM:  return "checksum";
    case E_NUMBER:    return "bad number";
    case E_TOOLONG:   return "line too long";
    case E_QUEUEFULL: return "queue full";
    case E_ARGS:      return "argument count";
    case E_SEQUENCE:  return "sequence gap";
    case E_ARC:       return "bad arc";
    case E_ALARM:     return "alarm, reset first";
    case E_BUSY:      return "busy, wait for idle";
    default:          return "out of range";
    }
}

/* Parse one decimal integer (optional sign) at the cursor: magnitude into
 * *mag, returns 1 for positive, 2 for negative, 0 if there is no number. */
static uint8_t parse_num(uint16_t *mag)
{
    uint16_t acc = 0;
    uint8_t sign = 1, digits = 0, d;
    char c = line[cur];
    if (c == '-' || c == '+') {
        sign = (c == '-') ? 2 : 1;
        c = line[++cur];
    }
    while (c >= '0' && c <= '9') {
        d = (uint8_t)(c - '0');
        if (acc > 6553u) return 0;
        acc = (uint16_t)((acc << 3) + (acc << 1));
        acc += d;
        if (acc < d) return 0;            /* wrapped past 65535 */
        digits++;
        c = line[++cur];
    }
    if (!digits) return 0;
    *mag = acc;
    return sign;
}

/* An unsigned number 0..65535 at the cursor. */
static uint8_t parse_u16(uint16_t *v)
{
    return parse_num(v) == 1;
}

static void skip_separators(void)
{
    while (line[cur] == ' ' || line[cur] == ',' || line[cur] == '\t') {
        cur++;
    }
}

/* Parse the arguments after the command letter, up to the end or '*'. */
static uint8_t parse_args(uint8_t end)
{
    uint8_t sign;
    nargs = 0;
    arg_neg = 0;
    skip_separators();
    while (cur < end) {
        if (nargs == 6 || !(sign = parse_num(&arg_mag[nargs]))) {
            return E_NUMBER;
        }
        if (sign == 2) arg_neg |= (uint8_t)(1 << nargs);
        nargs++;
        if (cur < end && line[cur] != ' ' && line[cur] != ',' && line[cur] != '\t') {
            return E_NUMBER;
        }
        skip_separators();
    }
    return E_OK;
}

/* Argument k as a coordinate, -32767..32767. */
static uint8_t arg_i16(uint8_t k, int16_t *out)
{
    if (arg_mag[k] > 32767u) return 0;
    *out = (arg_neg & (1 << k)) ? -(int16_t)arg_mag[k] : (int16_t)arg_mag[k];
    return 1;
}

/* Argument k as a count or rate, 0..65535. */
static uint8_t arg_u16(uint8_t k, uint16_t *out)
{
    if (arg_neg & (1 << k)) return 0;
    *out = arg_mag[k];
    return 1;
}

static uint8_t cmd_motion(char cmd, uint16_t seq)
{
    int16_t v[4];
    uint16_t feed = 0, exit_rate = 0;
    uint8_t coords = (cmd == 'L') ? 2 : 4, k;
    if (nargs < coords || nargs > coords + 2) return E_ARGS;
    for (k = 0; k < coords; k++) {
        if (!arg_i16(k, &v[k])) return E_RANGE;
    }
    if (nargs > coords && !arg_u16(coords, &feed)) return E_RANGE;
    if (nargs > coords + 1 && !arg_u16(coords + 1, &exit_rate)) return E_RANGE;
    if (alarm_code) return E_ALARM;
    if (cmd == 'L') {
        return planner_line(v[0], v[1], feed, exit_rate, seq);
    }
    return planner_arc(v[0], v[1], v[2], v[3], cmd == 'C', feed, exit_rate, seq);
}

/* $0 acceleration divisor, $1 ramp shape, $2 default feed, $3 pen delay. */
#define SETTINGS 4
static RAMP_ROM uint16_t setting_min[SETTINGS] = {1, 0, 15, 1};
static RAMP_ROM uint16_t setting_max[SETTINGS] = {50, 1, 65535u, 5000};

static uint16_t setting_get(uint8_t k)
{
    switch (k) {
    case 0: return st_accel;
    case 1: return st_shape;
    case 2: return default_feed;
    default: return pen_delay_ms;
    }
}

static uint8_t cmd_setting(uint8_t end)
{
    uint16_t key, value;
    uint8_t k;
    if (cur >= end) {
        for (k = 0; k < SETTINGS; k++) {
            hal_putc('$');
            put_i32(k);
            hal_putc('=');
            put_i32(setting_get(k));
            put_eol();
        }
        return E_OK;
    }
    if (line[cur] == 'I' && cur + 1 == end) {
        put_str("[" FW_NAME " " FW_VERSION);
        put_field('Q', QUEUE_SIZE);
        put_field('B', RX_SIZE);
        put_field('R', ramp_rate[st_shape][0]);
        put_field('T', ramp_rate[st_shape][RAMP_LEVELS - 1]);
        put_field('A', ramp_accel_trap);
        hal_putc(']');
        put_eol();
        return E_OK;
    }
    if (!parse_u16(&key) || line[cur] != '=') return E_NUMBER;
    cur++;
    if (!parse_u16(&value) || cur != end) return E_NUMBER;
    if (key >= SETTINGS || value < setting_min[key] || value > setting_max[key]) return E_RANGE;
    if (st_running || queue_used()) return E_BUSY;
    switch ((uint8_t)key) {
    case 0: st_accel = (uint8_t)value; break;
    case 1: st_shape = (uint8_t)value; break;
    case 2: default_feed = value; break;
    default: pen_delay_ms = value; break;
    }
    return E_OK;
}

static uint8_t run_command(uint8_t end, uint16_t seq)
{
    char cmd;
    uint8_t err;
    skip_separators();
    if (cur >= end) {
        return E_OK;                      /* empty line */
    }
    cmd = line[cur++];
    if (cmd == '$') {
        return cmd_setting(end);
    }
    err = parse_args(end);
    if (err) return err;
    switch (cmd) {
    case 'L':
    case 'C':
    case 'A':
        return cmd_motion(cmd, seq);
    case 'P':
    case 'D':
        if (nargs != 1) return E_ARGS;
        if (arg_neg || (cmd == 'P' && arg_mag[0] > 1)) return E_RANGE;
        if (alarm_code) return E_ALARM;
        return cmd == 'P' ? planner_pen((uint8_t)arg_mag[0], seq) : planner_dwell(arg_mag[0], seq);
    case 'H':
        if (nargs != 0) return E_ARGS;
        if (st_running || queue_used()) return E_BUSY;
        HAL_CRITICAL_BEGIN();
        pos_x = 0;
        pos_y = 0;
        HAL_CRITICAL_END();
        return E_OK;
    default:
        return E_UNKNOWN;
    }
}

static void reply_ok(uint8_t machine, uint16_t seq)
{
    put_str("ok");
    if (machine) put_field('N', seq);
    put_field('Q', QUEUE_FREE());
    put_eol();
}

static void reply_err(uint8_t machine, uint16_t seq, uint8_t code)
{
    put_str("err");
    if (machine) put_field('N', seq);
    put_field('E', code);
    hal_putc(' ');
    put_str(error_text(code));
    put_eol();
}

static void reply_resend(uint8_t code)
{
    put_str("rs");
    put_field('N', expected_seq);
    put_field('E', code);
    put_eol();
    resend_asked = 1;
}

static void execute_line(void)
{
    uint16_t seq, sum;
    uint8_t end = line_len, err, machine;
    int16_t ahead;

    line[line_len] = 0;
    cur = 0;
    skip_separators();
    machine = (line[cur] == 'N') || line_star;
    if (line_long) {
        if (machine) reply_resend(E_TOOLONG); else reply_err(0, 0, E_TOOLONG);
        return;
    }
    if (!machine) {
        err = run_command(end, 0);
        if (err) reply_err(0, 0, err); else reply_ok(0, 0);
        return;
    }
    /* N<seq> <command> *<checksum> */
    end = line_star ? (uint8_t)(line_star - 1) : 0;
    if (line[cur] != 'N' || !line_star) {
        reply_resend(E_CHECKSUM);
        return;
    }
    cur = line_star;
    if (!parse_u16(&sum) || line[cur] != 0 || sum != line_xor) {
        reply_resend(E_CHECKSUM);
        return;
    }
    cur = 1;
    while (line[cur] == ' ') cur++;
    if (!parse_u16(&seq)) {
        reply_resend(E_CHECKSUM);
        return;
    }
    ahead = (int16_t)(seq - expected_seq);
    if (ahead < 0) {
        reply_ok(1, seq);                 /* already executed: acknowledge again */
        return;
    }
    if (ahead > 0) {
        if (!resend_asked) reply_resend(E_SEQUENCE);
        return;
    }
    resend_asked = 0;
    err = run_command(end, seq);
    if (err == E_QUEUEFULL) {
        reply_resend(E_QUEUEFULL);        /* not executed: the host sends it again */
        return;
    }
    expected_seq++;
    if (err) reply_err(1, seq, err); else reply_ok(1, seq);
}

static void receive_byte(uint8_t c)
{
    if (c == '\n' || c == '\r') {
        if (line_len || line_long) {
            execute_line();
        }
        line_len = 0;
        line_xor = 0;
        line_star = 0;
        line_long = 0;
        return;
    }
    if (line_len >= LINE_MAX) {
        line_long = 1;
        return;
    }
    if (c == '*' && !line_star) {
        line_star = (uint8_t)(line_len + 1);
    } else if (!line_star) {
        line_xor ^= c;
    }
    line[line_len++] = (char)c;
}

void protocol_poll(void)
{
    uint8_t flags = rt_flags;

    if (flags & (RTF_ESTOP | RTF_RESET)) {
        rt_flags &= (uint8_t)~(RTF_ESTOP | RTF_RESET);
        HAL_TIMER_HALT();
        stepper_abort();
        planner_flush();
        st_hold = 0;
        rx_tail = rx_flush_to;
        line_len = 0;
        line_xor = 0;
        line_star = 0;
        line_long = 0;
        if (flags & RTF_ESTOP) {
            protocol_alarm(ALARM_ESTOP);
        } else {
            alarm_code = 0;
            put_str("[reset]");
            put_eol();
        }
    }
    if (flags & RTF_RESUME) {
        rt_flags &= (uint8_t)~RTF_RESUME;
        stepper_resume();
    }
    if (flags & RTF_STATUS) {
        rt_flags &= (uint8_t)~RTF_STATUS;
        report_status();
    }
    if (rx_overflow) {
        rx_overflow = 0;
        line_long = 1;                    /* bytes were lost: the line cannot be trusted */
    }
    while (rx_tail != rx_head) {
        uint8_t c = rx_buf[rx_tail & (RX_SIZE - 1)];
        rx_tail++;
        receive_byte(c);
        if (c == '\n') break;             /* let the stepper start between lines */
    }
    if (!st_running && !st_hold && !alarm_code && queue_used()) {
        stepper_start();
    }
}
