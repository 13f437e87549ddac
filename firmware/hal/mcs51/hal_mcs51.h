/* hal_mcs51.h - the core's hardware layer on the STC89C52RC.
 * Timer 0 (16-bit, high priority) paces the steps; port 1 carries step,
 * direction and pen outputs (firmware/README.md has the pin map). */
#ifndef HAL_MCS51_H
#define HAL_MCS51_H

#include <8052.h>
#include <stdint.h>

#define FAST __data
/* C99 inline without extern: SDCC expands it and emits no unused copy. */
#define INLINE inline
#define XDATA __xdata
#define IDATA __idata

/* P1.5-P1.7 are inputs (limit switches, spare): keep them written high. */
#define HAL_PORT_IDLE 0xE0

/* Cycles lost between the overflow and the reload while the timer is stopped:
 * the reload adds them back so the step period is exact. */
#define TIMER_STOPPED_CYCLES 7

#define STEPPER_ISR void stepper_isr(void) __interrupt(1) __using(1)

#define HAL_TIMER_ADVANCE(p) do {                                            \
        uint16_t t_;                                                         \
        TR0 = 0;                                                             \
        t_ = (((uint16_t)TH0 << 8) | TL0) - (uint16_t)(p) + TIMER_STOPPED_CYCLES; \
        TL0 = (uint8_t)t_;                                                   \
        TH0 = (uint8_t)(t_ >> 8);                                            \
        TR0 = 1;                                                             \
    } while (0)
#define HAL_TIMER_START(p) do {                                              \
        uint16_t t_ = (uint16_t)(0 - (uint16_t)(p));                         \
        TR0 = 0;                                                             \
        TL0 = (uint8_t)t_;                                                   \
        TH0 = (uint8_t)(t_ >> 8);                                            \
        TF0 = 0;                                                             \
        TR0 = 1;                                                             \
    } while (0)
#define HAL_TIMER_HALT() do { TR0 = 0; TF0 = 0; } while (0)
#define HAL_PORT_OUT(v) (P1 = (v))
#define HAL_SEGMENT_STARTED(s)
#define HAL_CRITICAL_BEGIN() (EA = 0)
#define HAL_CRITICAL_END() (EA = 1)

#endif
