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

extern XDATA uint8_t rx_buf[RX_SIZE];
extern FAST volatile uint8_t rx_head, rx_tail;
extern FAST volatile uint8_t rx_flush_to;   /* on reset/e-stop: drop input received before it */
extern volatile FLAG rx_overflow;           /* bytes were lost to a full ring */
/* Real-time requests for the main loop. */
extern volatile FLAG rt_status, rt_resume, rt_estop, rt_reset;

#define SERIAL_RX_BYTE(c) do {                                              \
    if ((c) == RT_STATUS) {                                                 \
        rt_status = 1;                                                      \
    } else if ((c) == RT_HOLD) {                                            \
        st_hold = 1;                                                        \
    } else if ((c) == RT_RESUME) {                                          \
        rt_resume = 1;                                                      \
    } else if ((c) == RT_ESTOP || (c) == RT_RESET) {                        \
        HAL_TIMER_HALT();                                                   \
        rx_flush_to = rx_head;                                              \
        if ((c) == RT_ESTOP) rt_estop = 1; else rt_reset = 1;               \
    } else if ((uint8_t)(rx_head - rx_tail) < RX_SIZE) {                    \
        rx_buf[rx_head & (RX_SIZE - 1)] = (c);                              \
        rx_head++;                                                          \
    } else {                                                                \
        rx_overflow = 1;                                                    \
    }                                                                       \
} while (0)

#endif
