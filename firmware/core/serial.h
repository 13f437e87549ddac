/* serial.h - the receive ring and the real-time bytes.
 *
 * SERIAL_RX_BYTE(c) is the whole receive path of the UART interrupt: it acts
 * on a real-time byte at once (an emergency stop halts the step timer before
 * the interrupt returns) and queues every other byte for the main loop.  It is
 * a macro so the 8051's interrupt needs no function call. */
#ifndef SERIAL_H
#define SERIAL_H

#include "config.h"
#include "hal.h"
#include "stepper.h"

#define RTF_STATUS 0x01
#define RTF_RESUME 0x02
#define RTF_ESTOP  0x04
#define RTF_RESET  0x08

extern XDATA uint8_t rx_buf[RX_SIZE];
extern FAST volatile uint8_t rx_head, rx_tail;
extern FAST volatile uint8_t rx_flush_to;   /* on reset/e-stop: drop input received before it */
extern FAST volatile uint8_t rx_overflow;
extern FAST volatile uint8_t rt_flags;

#define SERIAL_RX_BYTE(c) do {                                              \
    if ((c) == RT_STATUS) {                                                 \
        rt_flags |= RTF_STATUS;                                             \
    } else if ((c) == RT_HOLD) {                                            \
        st_hold = 1;                                                        \
    } else if ((c) == RT_RESUME) {                                          \
        rt_flags |= RTF_RESUME;                                             \
    } else if ((c) == RT_ESTOP || (c) == RT_RESET) {                        \
        HAL_TIMER_HALT();                                                   \
        rx_flush_to = rx_head;                                              \
        rt_flags |= ((c) == RT_ESTOP) ? RTF_ESTOP : RTF_RESET;              \
    } else if ((uint8_t)(rx_head - rx_tail) < RX_SIZE) {                    \
        rx_buf[rx_head & (RX_SIZE - 1)] = (c);                              \
        rx_head++;                                                          \
    } else {                                                                \
        rx_overflow = 1;                                                    \
    }                                                                       \
} while (0)

#endif
