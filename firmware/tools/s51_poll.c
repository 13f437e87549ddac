/* s51_poll.c: preloaded into the s51 simulator by tools/s51sim.py, it lets
 * the simulated UART look at its pseudo-terminal at most once every
 * POLL_NS of host time instead of at every instruction.
 *
 * With uart0_check_often=1 (typed lines must arrive whole, s51sim.py says
 * why) uCsim 0.6.4 asks select() about the pty before each instruction the
 * 8051 runs while its receiver is idle: a system call per instruction, half
 * of s51's time in the kernel and the simulation about five times slower.
 * Asked every 20 us instead, a byte waits at most that long (some tens of
 * instructions; a byte takes about 960 machine cycles at 9600 baud), and s51's
 * flow control still hands the firmware one byte at a time.  Only a
 * zero-timeout select() of one descriptor for reading is held back: the
 * command console's, asked once a million instructions, never waits.  And
 * the naps of the stopped simulator are short (nanosleep below). */
#define _GNU_SOURCE
#include <dlfcn.h>
#include <stddef.h>
#include <sys/select.h>
#include <time.h>

#define POLL_NS 20000LL
#define IDLE_NAP_NS 1000000L

typedef int select_fn(int, fd_set *, fd_set *, fd_set *, struct timeval *);

static long long asked_at[FD_SETSIZE];

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
