/* s51_poll.c: preloaded into the s51 simulator by tools/s51sim.py, it takes
 * three waits out of uCsim 0.6.4 that cost the tests most of their time and
 * change nothing the 8051 sees:
 *
 * - the UART looks at its pseudo-terminal at most once every POLL_NS of host
 *   time instead of at every instruction (select below);
 * - the stopped simulator naps 1 ms between looks at its console, not 100 ms
 *   (nanosleep below);
 * - the console's connection has Nagle's algorithm off (accept below).
 *
 * With uart0_check_often=1 (typed lines must arrive whole, s51sim.py says
 * why) uCsim asks select() about the pty before each instruction the 8051
 * runs while its receiver is idle: a system call per instruction, half of
 * s51's time in the kernel and the simulation about five times slower.
 * Asked every 20 us instead, a byte waits at most that long (some tens of
 * instructions; a byte takes about 960 machine cycles at 9600 baud), and s51's
 * flow control still hands the firmware one byte at a time.  Only a
 * zero-timeout select() of one descriptor for reading is held back: the
 * command console's, asked once a million instructions, never waits. */
#define _GNU_SOURCE
#include <dlfcn.h>
#include <stddef.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <sys/select.h>
#include <sys/socket.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

#define POLL_NS 20000LL
#define IDLE_NAP_NS 1000000L

typedef int select_fn(int, fd_set *, fd_set *, fd_set *, struct timeval *);

static long long asked_at[FD_SETSIZE];
static int console_fd = -1;        /* the -Z connection, once accepted */

static long long now_ns(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (long long)t.tv_sec * 1000000000LL + t.tv_nsec;
}

static int one_fd_poll(int nfds, fd_set *r, fd_set *w, fd_set *e, const struct timeval *tv)
{
    if (!tv || tv->tv_sec || tv->tv_usec || !r || w || e || nfds <= 0 || nfds > FD_SETSIZE
        || !FD_ISSET(nfds - 1, r))
        return 0;
    for (int fd = 0; fd < nfds - 1; fd++)
        if (FD_ISSET(fd, r))
            return 0;
    return 1;
}

int select(int nfds, fd_set *r, fd_set *w, fd_set *e, struct timeval *tv)
{
    static select_fn *real_select;
    if (!real_select)
        real_select = (select_fn *)dlsym(RTLD_NEXT, "select");
    if (one_fd_poll(nfds, r, w, e, tv)) {
        long long now = now_ns();
        if (now - asked_at[nfds - 1] < POLL_NS) {
            FD_ZERO(r);
            return 0;
        }
        asked_at[nfds - 1] = now;
    }
    return real_select(nfds, r, w, e, tv);
}

typedef int nanosleep_fn(const struct timespec *, struct timespec *);

/* Stopped, s51 looks at its command console between naps of 100 ms: a command
 * waited 50 ms on average for its turn, and a test that reads and sets the
 * simulated chip between runs sends hundreds.  The nap is 1 ms instead. */
int nanosleep(const struct timespec *req, struct timespec *rem)
{
    static nanosleep_fn *real_nanosleep;
    if (!real_nanosleep)
        real_nanosleep = (nanosleep_fn *)dlsym(RTLD_NEXT, "nanosleep");
    if (req && req->tv_sec == 0 && req->tv_nsec == 100000000L) {
        struct timespec nap = {0, IDLE_NAP_NS};
        return real_nanosleep(&nap, rem);
    }
    return real_nanosleep(req, rem);
}

typedef int accept_fn(int, struct sockaddr *, socklen_t *);

/* s51 writes its console's output a byte per write(): with Nagle's algorithm
 * on the connection each byte after the first waited for the host's delayed
 * acknowledgement, some 40 ms a command.  The console connection (-Z) is
 * accepted with TCP_NODELAY. */
int accept(int fd, struct sockaddr *addr, socklen_t *len)
{
    static accept_fn *real_accept;
    if (!real_accept)
        real_accept = (accept_fn *)dlsym(RTLD_NEXT, "accept");
    int conn = real_accept(fd, addr, len);
    if (conn >= 0) {
        int on = 1;
        setsockopt(conn, IPPROTO_TCP, TCP_NODELAY, &on, sizeof on);
        console_fd = conn;
    }
    return conn;
}

typedef ssize_t write_fn(int, const void *, size_t);

static write_fn *real_write;
static char console_out[8192];
static size_t console_len;

static void console_flush(void)
{
    size_t done = 0;
    while (done < console_len) {
        ssize_t n = real_write(console_fd, console_out + done, console_len - done);
        if (n <= 0)
            break;
        done += (size_t)n;
    }
    console_len = 0;
}

/* ... and a stop's text (its registers, some 500 bytes) went out as as many
 * packets.  The console's bytes are gathered up to the end of a line or the
 * prompt (a NUL byte) and sent together: a bounded run (tools/s51sim.py's
 * Sim.run_for) costs half the time. */
ssize_t write(int fd, const void *buf, size_t n)
{
    if (!real_write)
        real_write = (write_fn *)dlsym(RTLD_NEXT, "write");
    if (fd != console_fd || console_fd < 0)
        return real_write(fd, buf, n);
    if (console_len + n > sizeof console_out)
        console_flush();
    if (n > sizeof console_out)
        return real_write(fd, buf, n);
    memcpy(console_out + console_len, buf, n);
    console_len += n;
    const char *end = (const char *)buf + n - 1;
    if (*end == '\n' || *end == '\0')
        console_flush();
    return (ssize_t)n;
}
