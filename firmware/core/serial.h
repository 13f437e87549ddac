/* serial.h - the receive ring and the real-time bytes.
 *
 * SERIAL_RX_BYTE(c) is the whole receive path of the UART interrupt: it acts
 * on a real-time byte at once (an emergency stop halts the step timer before
 * the interrupt returns) and queues every other byte for the main loop.  It is
 * a macro so the 8051's interrupt needs no function call.
 *
 * One flipped bit turns a line's '8' into Ctrl-X and its '1' into '!', and a
 * dropped 'N' puts that digit right after a line end.  So reset, hold and
 * resume act only as a pair of the same byte between lines (after a line
 * end, a real-time byte, or at power-on): the first arms and is dropped, the
 * same byte next acts.  Any other byte disarms and is handled as if the
 * armed byte had not come, so a lone damaged byte never acts and never takes
 * a byte of the next line with it.  Inside a line the three are dropped and
 * arm nothing; the damaged line fails its checksum.  ESC is two bit flips
 * away from every byte a host sends in a line, and the status query is
 * harmless: both act anywhere, as single bytes. */
#ifndef SERIAL_H
#define SERIAL_H

#include "config.h"
#include "hal.h"
#include "stepper.h"

extern XDATA uint8_t rx_buf[RX_SIZE];
extern FAST volatile uint8_t rx_head, rx_tail;
extern FAST volatile uint8_t rx_flush_to;   /* on reset/e-stop: drop input received before it */
extern volatile FLAG rx_overflow;           /* bytes were lost to a full ring */
extern volatile FLAG rx_between_lines;      /* no line has started since the last line end */
/* The armed first byte of a pair, in two bits rather than a byte of
 * direct RAM: none 00, '!' 01, '~' 10, Ctrl-X 11 (rx_arm_a, rx_arm_b). */
extern volatile FLAG rx_arm_a, rx_arm_b;
/* Real-time requests for the main loop. */
extern volatile FLAG rt_status, rt_resume, rt_estop, rt_reset;
extern volatile FLAG rt_limit;              /* the step interrupt met a closed limit switch */
#define RT_HOLD_MATCH(c) ((c) == RT_HOLD || (c) == RT_RESUME)
#ifdef PANEL
extern volatile FLAG rt_star;
#define RT_STAR_MATCH(c) ((c) == RT_STAR && rx_between_lines)
#define RT_STAR_SET() (rt_star = 1)
#else
#define RT_STAR_MATCH(c) 0
#define RT_STAR_SET()
#endif

/* Stop the pulses at once and ask the main loop for an e-stop or a reset
 * (flag rt_estop or rt_reset), dropping the input received so far: from
 * the UART interrupt, the e-stop pin's interrupt or the panel. */
#define RT_STOP(flag) do {                                                  \
    HAL_TIMER_HALT();                                                       \
    rx_flush_to = rx_head;                                                  \
    (flag) = 1;                                                             \
} while (0)

#define SERIAL_RX_BYTE(c) do {                                              \
    if ((c) == RT_RESET || RT_HOLD_MATCH(c)) {                              \
        if (rx_between_lines) {                                             \
            if ((c) == RT_HOLD) {                                           \
                if (rx_arm_a || !rx_arm_b) {                                \
                    rx_arm_a = 0;                                           \
                    rx_arm_b = 1;                                           \
                    break;              /* armed: past the disarm below */  \
                }                                                           \
                STEPPER_HOLD();                                             \
            } else if ((c) == RT_RESUME) {                                  \
                if (!rx_arm_a || rx_arm_b) {                                \
                    rx_arm_a = 1;                                           \
                    rx_arm_b = 0;                                           \
                    break;                                                  \
                }                                                           \
                rt_resume = 1;                                              \
            } else {                                                        \
                if (!rx_arm_a || !rx_arm_b) {                               \
                    rx_arm_a = 1;                                           \
                    rx_arm_b = 1;                                           \
                    break;                                                  \
                }                                                           \
                RT_STOP(rt_reset);                                          \
            }                                                               \
        }                                                                   \
    } else if ((c) == RT_STATUS) {                                          \
        rt_status = 1;                                                      \
    } else if ((c) == RT_ESTOP) {                                           \
        RT_STOP(rt_estop);                                                  \
        rx_between_lines = 1;                                               \
    } else if (RT_STAR_MATCH(c)) {                                          \
        RT_STAR_SET();                                                      \
    } else if ((uint8_t)(rx_head - rx_tail) < RX_SIZE) {                    \
        rx_buf[rx_head & (RX_SIZE - 1)] = (c);                              \
        rx_head++;                                                          \
        /* if/else: an assigned comparison costs SDCC a bit of RAM */       \
        if ((c) == '\n' || (c) == '\r') {                                   \
            rx_between_lines = 1;                                           \
        } else {                                                            \
            rx_between_lines = 0;                                           \
        }                                                                   \
    } else {                                                                \
        rx_overflow = 1;                                                    \
        rx_between_lines = 0;                                               \
    }                                                                       \
    /* acted, or any other byte: nothing stays armed */                     \
    rx_arm_a = 0;                                                           \
    rx_arm_b = 0;                                                           \
} while (0)

#endif
