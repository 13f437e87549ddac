/* protocol.c - see protocol.h and firmware/PROTOCOL.md.
 *
 * A line is parsed only once it is complete, and a command changes nothing
 * unless every argument parsed: a bad line never moves the machine.  Lines
 * that carry a sequence number (N...) must also carry a valid checksum; they
 * are executed exactly once, in order: a repeat of an executed number is
 * acknowledged again without running, a gap or a damaged line asks the host
 * to resend from the expected number.
 *
 * Written for an 8 KB part: the state the functions share is global (SDCC
 * gives every local of a non-leaf function a fixed address anyway), flags
 * are bits, and constant text is assembled by the preprocessor. */
#include "protocol.h"
#ifdef __SDCC
#pragma noinduction     /* SDCC's induction variables cost this file 11 bytes of flash */
#endif
#include "planner.h"
#include "stepper.h"
#include "serial.h"
#include "ramp.h"
#include "panel.h"
#ifdef FOLLOW
#include "follow.h"
#endif

#define STR(x) #x
#define XSTR(x) STR(x)

uint8_t alarm_code;

static IDATA char line[LINE_MAX + 1];
/* CRC-16s (crc16): of the line's bytes before its '*', and of the reply
 * line so far. */
static XDATA uint16_t line_sum, tx_sum;
#define CRC_START 0xFFFFu
static FLAG line_star;            /* the line has a '*': the bytes from it on are not summed */
static FLAG resend_asked;         /* an rs is outstanding: drop later lines quietly */
static FLAG machine;              /* the line being executed is in machine form */
static SEQ_MEM uint16_t expected_seq;  /* next sequence number to execute */
static FLAG line_long;            /* the line overflowed LINE_MAX */

static IDATA char *FAST cur;      /* parse cursor into line[] */
/* Where the next received byte goes; while a line is executed, the end of
 * its command: the line's end, or its '*'. */
static IDATA char *FAST end;
static IDATA uint8_t arg_neg;     /* bit k set: argument k is negative */
static FAST uint8_t nargs;
/* The arguments' magnitudes are parsed straight into the planner's argument
 * block; a command turns them into its numbers in place. */
#define arg_mag plan_arg

#define num plan_t                 /* the number put_num prints */

#ifdef PANEL
static FLAG out_lcd;              /* out() writes to the LCD (protocol_lcd) */
static FLAG out_seg;              /* out() writes digits to the 7-segment display (protocol_segments) */
#define lcd_col nargs             /* the arguments are parsed and used before the LCD is written */
#endif

/* One byte into a CRC-16/CCITT-FALSE (polynomial 0x1021, start 0xFFFF, no
 * reflection, PROTOCOL.md), without a table: the eight shift-and-xor steps
 * folded into byte operations, so it costs a few dozen bytes of flash and no
 * 512-byte table.  It catches every error of up to three flipped bits and
 * every burst of up to 16 bits in a line, where a sum modulo 255 lets some
 * pairs of damaged bytes through. */
static void crc16(XDATA uint16_t *crc, uint8_t c)
{
    uint16_t t = *crc;
    uint8_t lo = (uint8_t)t, x = (uint8_t)(t >> 8) ^ c;
    x ^= x >> 4;
    lo ^= (uint8_t)(x << 4) ^ (x >> 3);   /* the new high byte */
    *crc = (uint16_t)((uint16_t)lo << 8 | (uint8_t)((uint8_t)(x << 5) ^ x));
}

#ifdef PANEL
/* Segments a..g on bits 0..6 (dp on bit 7), lit when 1. */
static const ROM uint8_t seg_font[10] = {
    0x3F, 0x06, 0x5B, 0x4F, 0x66, 0x6D, 0x7D, 0x07, 0x7F, 0x6F,
};
#endif

/* Every byte of a reply goes through here, summed for the line's checksum. */

static void out(uint8_t c)
{
#ifdef PANEL
    if (out_seg) {
        if (lcd_col < 4) panel_segments[lcd_col] = seg_font[(uint8_t)(c - '0')];
        lcd_col++;
        return;
    }
    if (out_lcd) {
        HAL_LCD_WRITE(c, 1);
        lcd_col++;
        return;
    }
#endif
    hal_putc(c);
    crc16(&tx_sum, c);
}

static void put_str(const ROM char *s)
{
    char c;
    while ((c = *s++) != 0) {
        out((uint8_t)c);
    }
}

static void put_u16(uint16_t v);

/* End a reply line with " *<checksum>": the CRC-16 of the bytes before the
 * '*' (crc16); the host trusts no reply that fails it. */
static void put_eol(void)
{
    out(' ');
    hal_putc('*');
    put_u16(tx_sum);
    tx_sum = CRC_START;
    hal_putc('\r');
    hal_putc('\n');
}

static RAMP_ROM uint32_t powers_of_ten[10] = {
    1000000000UL, 100000000UL, 10000000UL, 1000000UL, 100000UL, 10000UL, 1000UL, 100UL, 10UL, 1UL,
};

/* num in decimal, with a '-' if it is negative as an int32; most
 * significant digit first, so no buffer is needed.  Each digit by repeated
 * subtraction, as the 8051 has no 32-bit divide (the library's is long). */
static FLAG started;              /* put_num has printed a digit */

static void put_num(void)
{
    uint8_t k, d;
    uint32_t p;
    started = 0;
    if (num & 0x80000000UL) {           /* negative as an int32 */
        out('-');
        num = 0 - num;
    }
    for (k = 0; k < 10; k++) {
        p = powers_of_ten[k];
        d = 0;
        while (num >= p) {
            num -= p;
            d++;
        }
        if (d || started || k == 9) {
            out((uint8_t)('0' + d));
            started = 1;
        }
    }
}

static void put_u16(uint16_t v)
{
    num = v;
    put_num();
}

static void put_u8(uint8_t v)
{
    put_u16(v);
}

/* " <tag>", the start of a field */
static void put_tag(char tag)
{
    out(' ');
    out((uint8_t)tag);
}

/* " Q<free queue slots>" */
static void put_free(void)
{
    put_tag('Q');
    put_u8(QUEUE_FREE());
}

/* Start a new line. */
static void line_clear(void)
{
    end = line;
    line_sum = CRC_START;
    line_star = 0;
    line_long = 0;
}

void protocol_init(void)
{
    line_clear();
    tx_sum = CRC_START;
    expected_seq = 0;
    resend_asked = 0;
    alarm_code = 0;
    put_str(FW_NAME " " FW_VERSION " ready");
    put_eol();
}

static void put_coordinate(IDATA int32_t *v)
{
    num = (uint32_t)*v;
    put_num();
}

/* "X<x> Y<y>" of pos_copy */
static void put_position(void)
{
    out('X');
    put_coordinate(&pos_copy[0]);
    put_tag('Y');
    put_coordinate(&pos_copy[1]);
}

#ifdef PANEL
/* The LCD (display.c): line 1 the position, line 2 the text, both padded
 * with spaces; the reply printing's own code, its bytes sent to the LCD. */

static void lcd_line(uint8_t address)
{
    while (lcd_col < 16) out(' ');
    HAL_LCD_WRITE(address, 0);
    lcd_col = 0;
}

void protocol_lcd(const ROM char *text)
{
    stepper_snapshot();
    out_lcd = 1;
    lcd_col = 16;
    lcd_line(0x80);
    put_position();
    lcd_line(0xC0);
    put_str(text);
    lcd_line(0x80);
    out_lcd = 0;
}
#endif

#ifdef PANEL
/* v (0..9999) on the 7-segment display's right four digits, with leading
 * zeros: the digits of 10000 + v, printed as replies are, all but its
 * leading 1. */
void protocol_segments(uint16_t v)
{
    out_seg = 1;
    lcd_col = 0xFF;
    num = (uint32_t)v + 10000u;
    put_num();
    out_seg = 0;
}
#endif

/* A status report's start, one per state: put_str(states + its offset). */
static const ROM char states[] = "<Alarm \0<Hold \0<Run \0<Idle ";

static void report_status(void)
{
    uint8_t state;
    uint16_t v;
    stepper_snapshot();
    state = 21;
    if (st_running) state = 15;
    if (HOLDING) state = 8;
    if (alarm_code) state = 0;
    put_str(states + state);
    put_position();
#ifdef ZAXIS
    put_tag('Z');
    HAL_CRITICAL_BEGIN();
    num = (uint32_t)pos_z;
    HAL_CRITICAL_END();
    put_num();
#endif
    put_free();
    put_tag('N');
    put_u16(expected_seq);
    put_tag('S');
    /* 16-bit values the step interrupt writes: read with it masked, so that a
     * segment load or underrun between the two byte reads cannot report half
     * of each (a few cycles of latency for the interrupt). */
    HAL_CRITICAL_BEGIN();
    v = st_seg.seq;
    HAL_CRITICAL_END();
    put_u16(v);
    put_tag('P');
#if BIT_PEN != 0x10
#error "the status report takes the pen from bit 4"
#endif
    put_u8((uint8_t)(st_port & BIT_PEN) >> 4);
    put_tag('U');
    HAL_CRITICAL_BEGIN();
    v = st_underruns;
    HAL_CRITICAL_END();
    put_u16(v);
    put_tag('A');
    put_u8(alarm_code);
#ifdef FOLLOW
    put_tag('B');
    put_u8(HAL_SENSORS());
    put_tag('F');
    put_u8(follow_state);
    put_tag('W');
    num = follow_travelled();
    put_num();
#endif
    out('>');
    put_eol();
}

/* Each text at its offset: alarm_texts + offset. */
static const ROM char alarm_texts[] = "reset\0alarm estop\0alarm limit";

static const ROM uint8_t alarm_offset[3] = {0, 6, 18};   /* per alarm_code */

const ROM char *alarm_text(void)
{
    return alarm_texts + alarm_offset[alarm_code];
}

void protocol_alarm(uint8_t code)
{
    HAL_TIMER_HALT();
    alarm_code = code;
    stepper_abort();
    planner_flush();
#ifdef FOLLOW
    follow_abort();
#endif
    st_hold = 0;
#ifdef PANEL
    panel_stop();
#endif
    out('[');
    put_str(alarm_text());
    out(']');
    put_eol();
}


/* Move the cursor past spaces, commas and tabs: how many. */
static uint8_t skip_separators(void)
{
    IDATA char *start = cur;
    char c;
    while ((c = *cur) == ' ' || c == ',' || c == '\t') {
        cur++;
    }
    return (uint8_t)(cur - start);
}

/* Parse one decimal integer (optional sign) at the cursor: magnitude into
 * *mag, returns 1 for positive, 2 for negative, 0 if there is no number or
 * it is over 65535. */
static uint8_t parse_num(IDATA uint16_t *mag)
{
    IDATA char *first;
    uint16_t acc = 0;
    uint8_t sign = 1, d;
    d = *cur;
    if (d == '-') sign = 2;
    if (d == '-' || d == '+') cur++;
    first = cur;
    while ((d = (uint8_t)(*cur - '0')) <= 9) {
        if (acc > 6553u) return 0;
        acc = (uint16_t)((acc << 2) + acc);   /* acc * 10 + d, without a multiply */
        acc = (uint16_t)(acc << 1) + d;
        if (acc < d) return 0;            /* wrapped past 65535 */
        cur++;
    }
    if (cur == first) return 0;
    *mag = acc;
    return sign;
}

/* An unsigned number 0..65535 at the cursor, into arg_mag[0]. */
static uint8_t parse_u16(void)
{
    return parse_num(&arg_mag[0]) == 1;
}

static const ROM uint8_t arg_bit[6] = {1, 2, 4, 8, 16, 32};  /* 1 << k: no shift loop */

/* Parse the arguments after the command letter, up to the end. */
static uint8_t parse_args(void)
{
    uint8_t sign;
    IDATA uint16_t *a = arg_mag;
    do {
        *a++ = 0;                         /* absent: 0, a motion's feed and exit too */
    } while (a != arg_mag + 6);
    nargs = 0;
    arg_neg = 0;
    skip_separators();
    while (cur < end) {
        if (nargs == 6 || !(sign = parse_num(&arg_mag[nargs]))) {
            return E_NUMBER;
        }
        if (sign == 2) arg_neg |= arg_bit[nargs];
        nargs++;
        if (!skip_separators() && cur < end) {
            return E_NUMBER;              /* a number runs on into something else */
        }
    }
    return E_OK;
}

/* $0 acceleration divisor, $1 ramp shape, $2 default feed, $3 pen delay. */
static RAMP_ROM uint16_t setting_range[SETTINGS][2] = {   /* least, greatest */
    {1, 50}, {0, RAMP_SHAPES - 1}, {15, 65535u}, {1, 5000},
};

#if SETTINGS & (SETTINGS - 1)
#error "cmd_setting: the range check of the key takes SETTINGS to be a power of two"
#endif
static uint8_t cmd_setting(void)
{
    const RAMP_ROM uint16_t *range;
    uint8_t key;
    if (cur >= end) {
        for (key = 0; key < SETTINGS; key++) {
            out('$');
            out((uint8_t)('0' + key));
            out('=');
            put_u16(setting[key]);
            put_eol();
        }
        return E_OK;
    }
    if (*cur == 'I' && cur + 1 == end) {
        put_str("[" FW_NAME " " FW_VERSION " Q" XSTR(QUEUE_SIZE) " B" XSTR(RX_SIZE)
                " R" XSTR(RAMP_R0) " T" XSTR(LINE_TOP) " A" XSTR(RAMP_ACCEL_TRAP) "]");
        put_eol();
        return E_OK;
    }
    if (!parse_u16() || *cur != '=') return E_NUMBER;   /* $<key>=<value> */
    cur++;
    if (parse_num(&arg_mag[1]) != 1 || cur != end) return E_NUMBER;
    if (arg_mag[0] & (uint16_t)~(SETTINGS - 1)) return E_RANGE;   /* >= SETTINGS, a power of two */
    range = setting_range[(uint8_t)arg_mag[0]];
    if (arg_mag[1] < range[0] || arg_mag[1] > range[1]) return E_RANGE;
    if (planner_busy()) return E_BUSY;
    setting[(uint8_t)arg_mag[0]] = arg_mag[1];      /* key again: not kept across the call */
    return E_OK;
}

/* The commands' letters, and for each the fewest arguments, with MOTION
 * for a motion command: its coordinates (-32767..32767; the other arguments
 * are not negative) are those arguments, then up to two more, feed and exit. */
#define MOTION 0x80
#ifdef ZAXIS
#define Z_COMMAND "Z"
#define Z_ARGS MOTION | 1,
#else
#define Z_COMMAND
#define Z_ARGS
#endif
#define D_COMMAND "D"
#define D_ARGS 1,
#ifdef FOLLOW
#define F_COMMAND "F"
#define F_ARGS , 4
#else
#define F_COMMAND
#define F_ARGS
#endif
static const ROM char command_letters[] = "LCA" Z_COMMAND "P" D_COMMAND "H" F_COMMAND;
static const ROM uint8_t command_args[] = {
    MOTION | 2, MOTION | 4, MOTION | 4, Z_ARGS 1, D_ARGS 0 F_ARGS
};

/* The command in cur..end, as command number plan_seq. */
static uint8_t run_command(void)
{
    IDATA uint16_t *a;
    uint8_t k, coords, span;
    char cmd;
    skip_separators();
    if (cur >= end) {
        return E_OK;                      /* empty line */
    }
    cmd = *cur++;
    if (cmd == '$') {
        return cmd_setting();
    }
    k = parse_args();
    if (k) return k;
    for (k = 0; ; k++) {
        if (!command_letters[k]) return E_UNKNOWN;
        if (command_letters[k] == cmd) break;
    }
    k = command_args[k];
    coords = 0;
    span = 0;
    if (k & MOTION) {
        k -= MOTION;
        coords = k;
        span = 2;                         /* feed and exit */
    }
#ifdef FOLLOW
    if (cmd == 'F') span = 1;             /* the feed */
#endif
    if ((uint8_t)(nargs - k) > span) return E_ARGS;
    a = arg_mag;
    for (k = coords; k; k--, a++, arg_neg >>= 1) {
        if (*a & 0x8000u) return E_RANGE;
        if (arg_neg & 1) *a = 0 - *a;
    }
    if (arg_neg) return E_RANGE;          /* only coordinates are negative */
    if (cmd == 'P' && arg_mag[0] > 1) return E_RANGE;
    if (cmd == 'H') {
        if (planner_busy()) return E_BUSY;
        stepper_zero();
        return E_OK;
    }
    if (alarm_code) return E_ALARM;
#ifdef PANEL
    if (PANEL_BUSY()) return E_BUSY;      /* the panel is drawing a figure */
#endif
#ifdef FOLLOW
    if (cmd == 'F') {
        /* From rest only: the steering starts from the pen standing on the line. */
        if (arg_mag[0] >= FOLLOW_DIRS || !arg_mag[1] || arg_mag[3] > FOLLOW_MAX_GATE) return E_RANGE;
        if (nargs == 4) arg_mag[PLAN_FEED] = 0;
        if (planner_busy()) return E_BUSY;
        follow_args.heading = (uint8_t)arg_mag[0];
        follow_args.lost_steps = arg_mag[1];
        follow_args.max_steps = arg_mag[2];
        follow_args.home_steps = arg_mag[3];
        return planner_follow();
    }
#endif
    if (coords) {
        /* feed and exit, after the coordinates (a), byte by byte to
         * PLAN_FEED and PLAN_EXIT */
        IDATA uint8_t *from = (IDATA uint8_t *)a;
        IDATA uint8_t *to = (IDATA uint8_t *)&arg_mag[PLAN_FEED];
        do {
            *to++ = *from++;
        } while (to != (IDATA uint8_t *)&arg_mag[PLAN_EXIT + 1]);
        if (cmd == 'L') return planner_line();
#ifdef ZAXIS
        if (cmd == 'Z') return planner_z();
#endif
        return planner_arc(cmd == 'C');
    }
    if (cmd == 'D') return planner_dwell(arg_mag[0]);
    return planner_pen((uint8_t)arg_mag[0]);
}

#define RESEND 0x80     /* reply(RESEND | err): "rs N<expected_seq> E<err>" */

/* "ok Q<free>" or "err E<err>", with " N<seq>" after the word for a
 * machine line; or a request to resend (RESEND). */
static void reply(uint8_t err)
{
    const ROM char *word = "ok";
    SEQ_MEM uint16_t *seq = &plan_seq;
    if (err) word = "err";
    if (err & RESEND) {
        word = "rs";
        seq = &expected_seq;
        resend_asked = 1;
    }
    put_str(word);
    if (machine) {
        put_tag('N');
        put_u16(*seq);
    }
    err &= (uint8_t)~RESEND;
    if (err) {
        put_tag('E');
        put_u8(err);
    } else {
        put_free();
    }
    put_eol();
}

/* N<seq> <command> *<checksum>: 1 if the checksum matches and the sequence
 * number parsed, into arg_mag[0]; the command is left in cur..end. */
static uint8_t sequence_parsed(void)
{
    if (*cur != 'N' || !line_star) return 0;
    end = line;
    while (*end != '*') end++;
    cur = end + 1;
    if (!parse_u16() || *cur != 0 || arg_mag[0] != line_sum) return 0;
    cur = line + 1;
    while (*cur == ' ') cur++;
    return parse_u16();
}

static void execute_line(void)
{
    uint8_t err;
    uint16_t ahead;                       /* how far plan_seq is past expected_seq */

    *end = 0;
    cur = line;
    skip_separators();
    err = E_TOOLONG;
    machine = 0;
    if (*cur == 'N' || line_star) {
        machine = 1;
        err = RESEND | E_TOOLONG;
    }
    if (line_long) {
        reply(err);
        return;
    }
    if (machine) {
        if (!sequence_parsed()) {
            reply(RESEND | E_CHECKSUM);
            return;
        }
        plan_seq = arg_mag[0];
        ahead = plan_seq - expected_seq;
        if (ahead) {
            if ((int16_t)ahead < 0) {
                reply(E_OK);              /* already executed: acknowledge again */
            } else if (!resend_asked) {
                reply(RESEND | E_SEQUENCE);
            }
            return;
        }
        resend_asked = 0;
    } else
    {
        plan_seq = 0;
    }
    err = run_command();
    if (machine) {
        if (err == E_QUEUEFULL) {
            reply(RESEND | E_QUEUEFULL);    /* not executed: the host sends it again */
            return;
        }
        expected_seq++;
    }
    reply(err);
}

static void receive_byte(uint8_t c)
{
    if (c == '\n' || c == '\r') {
        if (end != line || line_long) {
            execute_line();
        }
        line_clear();
        return;
    }
    if (end == line + LINE_MAX) {
        line_long = 1;
        return;
    }
    *end++ = (char)c;
    if (!line_star) {
        if (c == '*') {
            line_star = 1;
        } else {
            crc16(&line_sum, c);
        }
    }
}

#ifdef FOLLOW
/* The follow key (the seed's mode key, in an image without the keypad):
 * held for FOLLOW_KEY_PASSES main-loop passes, so that a contact's bounce
 * is no press, it starts a follow where the board stands at rest, as F
 * would: with the last F's heading, lost steps, distance and gate
 * (follow_args), at the most feed; before any F, heading 0 with
 * FOLLOW_KEY_LOST and FOLLOW_KEY_GATE.  Once a press: held on, it starts
 * nothing more. */
static uint8_t key_passes;

static void follow_key(void)
{
    if (!HAL_FOLLOW_KEY()) {
        key_passes = 0;
        return;
    }
    if (key_passes == FOLLOW_KEY_PASSES || ++key_passes != FOLLOW_KEY_PASSES)
        return;
    if (alarm_code || planner_busy())
        return;
    if (!follow_args.lost_steps) {          /* no F since reset (XRAM starts cleared) */
        follow_args.lost_steps = FOLLOW_KEY_LOST;
        follow_args.home_steps = FOLLOW_KEY_GATE;
    }
    plan_arg[PLAN_FEED] = 0;
    planner_follow();
}
#endif

void protocol_poll(void)
{
    uint8_t c;
    if (rt_estop || rt_reset) {
        rt_reset = 0;
        HAL_TIMER_HALT();
        rx_tail = rx_flush_to;
        line_clear();
        c = 0;                            /* a reset */
        if (rt_estop) {
            rt_estop = 0;
            c = ALARM_ESTOP;
        }
        protocol_alarm(c);
    }
    if (rt_limit) {
        rt_limit = 0;
        protocol_alarm(ALARM_LIMIT);
    }
    if (rt_resume) {
        rt_resume = 0;
        stepper_resume();
    }
    if (rt_status) {
        rt_status = 0;
        report_status();
    }
    if (rx_overflow) {
        rx_overflow = 0;
        line_long = 1;                    /* bytes were lost: the line cannot be trusted */
    }
    while (rx_tail != rx_head) {
        c = rx_buf[rx_tail & (RX_SIZE - 1)];
        rx_tail++;
        receive_byte(c);
        if (c == '\n') break;             /* let the stepper start between lines */
    }
    if (!st_running && !HOLDING && !alarm_code && queue_used()) {
        stepper_start();
    }
#ifdef FOLLOW
    follow_service();
    follow_key();
#endif
}
