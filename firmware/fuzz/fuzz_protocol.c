/* fuzz_protocol.c - the firmware's receive path and protocol parser under a
 * fuzzer, on the host build of the core (hal/host/core_api.c).
 *
 * One input is a byte stream arriving on the UART.  It is fed in small
 * chunks, with the main loop and the step interrupt run between chunks, as
 * on the board.  Checked on every input:
 *   - no crash, no out-of-bounds access, no undefined behaviour (build with
 *     -fsanitize=address,undefined);
 *   - no hang: every input is finished under an alarm;
 *   - every reply line the firmware sends ends in " *<sum>\r\n" with the
 *     right CRC-16 (PROTOCOL.md), and none is over 80 bytes.
 *
 * With clang and libFuzzer:
 *   clang -g -O1 -fsanitize=fuzzer,address,undefined -Icore \
 *       fuzz/fuzz_protocol.c hal/host/core_api.c core/\*.c build/ramp_table.c
 * With gcc (no libFuzzer): -DFUZZ_MAIN builds a small coverage-guided fuzzer
 * of its own.  Compile the core with -fsanitize-coverage=trace-pc and this
 * file without it; then
 *   ./fuzz_protocol ITERATIONS [SEED]
 * mutates a corpus of valid lines, keeps every input that reaches new code,
 * and prints what it did.  tests/test_firmware_fuzz.py does exactly that. */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

void core_reset(void);
void core_rx(const uint8_t *data, uint32_t n);
void core_poll(void);
int core_tick(void);
int core_timer_on(void);
uint32_t core_tx_read(uint8_t *out, uint32_t cap);

#define MAX_REPLY 80
#define TICKS_PER_CHUNK 256
#define TICKS_AT_END 200000L

static uint8_t reply[MAX_REPLY + 2];
static uint32_t reply_len;

static void fail(const char *why)
{
    fprintf(stderr, "fuzz_protocol: %s: '%.*s'\n", why, (int)reply_len, (const char *)reply);
    abort();
}

/* The protocol's CRC-16/CCITT-FALSE, bit by bit as its definition reads:
 * a second formula beside the firmware's byte-wise one. */
static uint16_t crc16_add(uint16_t crc, uint8_t c)
{
    int k;
    crc ^= (uint16_t)(c << 8);
    for (k = 0; k < 8; k++) {
        crc = (uint16_t)((crc & 0x8000u) ? ((unsigned)crc << 1) ^ 0x1021u : (unsigned)crc << 1);
    }
    return crc;
}

/* A reply line: "<text> *<decimal sum>" before "\r\n". */
static void check_reply(void)
{
    uint32_t star = reply_len, k, sum = 0, digits = 0;
    uint16_t crc = 0xFFFFu;
    while (star > 0 && reply[star - 1] != '*') star--;
    if (star == 0) fail("reply without a checksum");
    for (k = 0; k + 1 < star; k++) {
        crc = crc16_add(crc, reply[k]);
    }
    for (k = star; k < reply_len; k++) {
        if (reply[k] < '0' || reply[k] > '9') fail("checksum is not a number");
        sum = sum * 10 + (uint32_t)(reply[k] - '0');
        digits++;
    }
    if (digits == 0 || digits > 5 || sum != crc) fail("wrong reply checksum");
}

static void drain_replies(void)
{
    uint8_t buf[256];
    uint32_t n, k;
    while ((n = core_tx_read(buf, sizeof buf)) != 0) {
        for (k = 0; k < n; k++) {
            uint8_t c = buf[k];
            if (c == '\n') {
                if (reply_len == 0 || reply[reply_len - 1] != '\r') fail("line end without CR");
                reply_len--;
                check_reply();
                reply_len = 0;
            } else if (reply_len >= MAX_REPLY + 1) {
                fail("reply line too long");
            } else {
                reply[reply_len++] = c;
            }
        }
    }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    size_t i = 0;
    long ticks;
    int k;
    reply_len = 0;
    core_reset();
    drain_replies();
    while (i < size) {
        size_t n = 1 + (data[i] % 24);     /* chunk sizes vary with the input */
        if (n > size - i) n = size - i;
        core_rx(data + i, (uint32_t)n);
        i += n;
        for (k = 0; k < 4; k++) core_poll();
        for (k = 0; k < TICKS_PER_CHUNK && core_timer_on(); k++) {
            core_tick();
            if ((k & 31) == 0) core_poll();
        }
        drain_replies();
    }
    for (ticks = 0; ticks < TICKS_AT_END && core_timer_on(); ticks++) {
        core_tick();
        if ((ticks & 63) == 0) core_poll();
    }
    core_poll();
    drain_replies();
    return 0;
}

#ifdef FUZZ_MAIN
#include <signal.h>
#include <unistd.h>

/* --- coverage: gcc's -fsanitize-coverage=trace-pc calls this on every edge ---- */
#define MAP_BITS 16
static uint8_t seen_map[1u << MAP_BITS];
static uint32_t new_edges, total_edges;

void __sanitizer_cov_trace_pc(void)
{
    uintptr_t pc = (uintptr_t)__builtin_return_address(0);
    uint32_t h = (uint32_t)((pc * 0x9E3779B97F4A7C15ull) >> (64 - MAP_BITS));
    if (!seen_map[h]) {
        seen_map[h] = 1;
        new_edges++;
        total_edges++;
    }
}

/* --- inputs ----------------------------------------------------------------------- */
#define MAX_INPUT 512
#define MAX_CORPUS 4096

typedef struct {
    uint8_t data[MAX_INPUT];
    size_t size;
} input_t;

static input_t corpus[MAX_CORPUS];
static size_t corpus_len;
static uint64_t rng_state = 88172645463325252ull;

static uint32_t rnd(uint32_t n)
{
    rng_state ^= rng_state << 13;
    rng_state ^= rng_state >> 7;
    rng_state ^= rng_state << 17;
    return n ? (uint32_t)(rng_state % n) : 0;
}

static size_t machine_line(uint8_t *out, size_t cap, unsigned seq, const char *cmd)
{
    char body[96];
    uint16_t crc = 0xFFFFu;
    size_t k, n = (size_t)snprintf(body, sizeof body, "N%u %s ", seq, cmd);
    for (k = 0; k < n; k++) {
        crc = crc16_add(crc, (uint8_t)body[k]);
    }
    n = (size_t)snprintf((char *)out, cap, "%s*%u\n", body, (unsigned)crc);
    return n < cap ? n : cap;
}

static const char *const seeds[] = {
    "L 400 -300", "L 10 0 2000 500", "C 20 0 10 0", "A 0 0 0 -15 3000 0", "C 100 100 100 0",
    "P 1", "P 0", "D 5", "H", "$", "$I", "$2=3000", "$0=50", "$1=1", "$3=5000", "$9=1",
    "L 32767 -32767 65535 65535", "L -32768 0", "A 3 4 0 5", "L", "L 1 2 3 4 5", "X 1 2",
    "L 1,2", "L\t-5 +6", "L 99999 1", "P 2", "D -1", "C 0 0 0 0",
};

static void add_seed(const uint8_t *data, size_t size)
{
    if (corpus_len < MAX_CORPUS && size <= MAX_INPUT) {
        memcpy(corpus[corpus_len].data, data, size);
        corpus[corpus_len].size = size;
        corpus_len++;
    }
}

static void build_seeds(void)
{
    uint8_t buf[MAX_INPUT];
    size_t k, n;
    for (k = 0; k < sizeof seeds / sizeof seeds[0]; k++) {
        n = machine_line(buf, sizeof buf, 0, seeds[k]);
        n += machine_line(buf + n, sizeof buf - n, 1, seeds[(k + 1) % (sizeof seeds / sizeof seeds[0])]);
        add_seed(buf, n);
        n = (size_t)snprintf((char *)buf, sizeof buf, "%s\n?", seeds[k]);
        add_seed(buf, n);
    }
    add_seed((const uint8_t *)"?!~\x18\x1b\n?", 7);
    /* Hold, resume and reset act as pairs between lines: the pairs, a pair
     * split by another byte, and pairs inside a line. */
    add_seed((const uint8_t *)"\n!!?~~?\x18\x18?", 10);
    add_seed((const uint8_t *)"\n!~!\x18?\x18\n~L!!1~~ 1\x18\x18\n?", 21);
}

static const uint8_t interesting[] = {'\n', '\r', '*', 'N', ' ', ',', '-', '+', '0', '9', '?', '!',
                                      '~', 0x18, 0x1b, 0x00, 0xff, '$', '=', 'L', 'C', 'A'};

static void mutate(input_t *in)
{
    int rounds = 1 + (int)rnd(8);
    while (rounds--) {
        size_t pos = in->size ? rnd((uint32_t)in->size) : 0;
        switch (rnd(7)) {
        case 0:                                   /* flip a bit */
            if (in->size) in->data[pos] ^= (uint8_t)(1u << rnd(8));
            break;
        case 1:                                   /* an interesting byte */
            if (in->size) in->data[pos] = interesting[rnd(sizeof interesting)];
            break;
        case 2:                                   /* insert a byte */
            if (in->size < MAX_INPUT) {
                memmove(in->data + pos + 1, in->data + pos, in->size - pos);
                in->data[pos] = rnd(2) ? interesting[rnd(sizeof interesting)] : (uint8_t)rnd(256);
                in->size++;
            }
            break;
        case 3:                                   /* delete a byte */
            if (in->size) {
                memmove(in->data + pos, in->data + pos + 1, in->size - pos - 1);
                in->size--;
            }
            break;
        case 4: {                                 /* append a valid line */
            uint8_t line[96];
            size_t n = machine_line(line, sizeof line, rnd(4) ? rnd(8) : rnd(65536),
                                    seeds[rnd(sizeof seeds / sizeof seeds[0])]);
            if (in->size + n <= MAX_INPUT) {
                memcpy(in->data + in->size, line, n);
                in->size += n;
            }
            break;
        }
        case 5: {                                 /* splice in another input */
            const input_t *o = &corpus[rnd((uint32_t)corpus_len)];
            size_t from = o->size ? rnd((uint32_t)o->size) : 0, n = o->size - from;
            if (pos + n > MAX_INPUT) n = MAX_INPUT - pos;
            memcpy(in->data + pos, o->data + from, n);
            if (pos + n > in->size) in->size = pos + n;
            break;
        }
        default:                                  /* repeat a run of bytes (long lines) */
            if (in->size && in->size < MAX_INPUT) {
                size_t n = 1 + rnd(64);
                if (in->size + n > MAX_INPUT) n = MAX_INPUT - in->size;
                memmove(in->data + pos + n, in->data + pos, in->size - pos);
                memset(in->data + pos, in->data[pos + n < in->size + n ? pos + n : pos], n);
                in->size += n;
            }
        }
    }
}

static void on_alarm(int sig)
{
    (void)sig;
    static const char msg[] = "fuzz_protocol: an input ran for more than 5 s (hang)\n";
    if (write(2, msg, sizeof msg - 1) < 0) _exit(3);
    _exit(3);
}

int main(int argc, char **argv)
{
    long iterations = argc > 1 ? atol(argv[1]) : 100000;
    long it, kept = 0;
    input_t in;
    if (argc > 2) rng_state ^= (uint64_t)atoll(argv[2]) * 0x9E3779B97F4A7C15ull;
    signal(SIGALRM, on_alarm);
    build_seeds();
    for (size_t k = 0; k < corpus_len; k++) {
        alarm(5);
        LLVMFuzzerTestOneInput(corpus[k].data, corpus[k].size);
    }
    for (it = 0; it < iterations; it++) {
        in = corpus[rnd((uint32_t)corpus_len)];
        mutate(&in);
        new_edges = 0;
        alarm(5);
        LLVMFuzzerTestOneInput(in.data, in.size);
        if (new_edges) {
            add_seed(in.data, in.size);
            kept++;
        }
    }
    alarm(0);
    printf("fuzz_protocol: %ld inputs, %zu in the corpus (%ld found new code), %u edges covered\n",
           iterations, corpus_len, kept, total_edges);
    return 0;
}
#endif
