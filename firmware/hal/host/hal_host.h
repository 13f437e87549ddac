/* hal_host.h - the core's hardware layer on a PC: the step timer becomes a
 * "next tick after N machine cycles" value that the caller (tests, the mock
 * board) honours in simulated or real time; the port becomes a variable. */
#ifndef HAL_HOST_H
#define HAL_HOST_H

#include <stdint.h>

#define FAST
#define ROM
#define INLINE static inline
#define XDATA
#define IDATA
#define FLAG uint8_t
#ifdef DRIVE_PHASE
#define HAL_PORT_IDLE PHASE_START
#else
#define HAL_PORT_IDLE 0x00
#endif

extern uint16_t host_period;      /* cycles until the next step interrupt */
extern uint8_t host_timer_on;
extern uint8_t host_port;
extern uint8_t host_port2;        /* phase drive: the Y windings (P2 on the board) */
void host_segment_started(uint16_t seq);

#define STEPPER_ISR void stepper_isr(void)
#define HAL_PERIOD(p) ((uint16_t)(p))
#define HAL_PERIOD_LONGER(a, b) ((uint16_t)(a) > (uint16_t)(b))
#define HAL_TIMER_ADVANCE(r) (host_period = (r))
#define HAL_TIMER_START(p) (host_period = (p), host_timer_on = 1)
#define HAL_TIMER_HALT() (host_timer_on = 0)
#define HAL_PORT_OUT(v) (host_port = (uint8_t)(v))
#define HAL_PORT2_OUT(v) (host_port2 = (uint8_t)(v))
#define HAL_SEGMENT_STARTED(s) host_segment_started(s)
#define HAL_STEPPER_SLOW()
#define HAL_MUL16U(a, b) ((uint32_t)(uint16_t)(a) * (uint16_t)(b))
#define HAL_MUL16S(a, b) ((uint32_t)((int32_t)(int16_t)(a) * (int16_t)(b)))
/* The panel's hardware (panel builds): the caller sets the key held down,
 * the closed limit switches (as BIT_X_DIR / BIT_Y_DIR) and the e-stop; the
 * LCD and the 7-segment display are recorded (core_api.c). */
extern uint8_t host_key, host_limits, host_estop;
extern uint8_t host_seg[8];
void host_lcd_write(uint8_t b, uint8_t rs);
#define HAL_KEY_SCAN() host_key
#define HAL_LIMITS_CLOSED() host_limits
#define HAL_ESTOP_ACTIVE() host_estop
#define HAL_LCD_WRITE(b, rs) host_lcd_write((b), (rs))
#define HAL_SEG_SHOW(i, pattern) (host_seg[i] = (pattern))
/* Line following (FOLLOW): the sensors on black, bit i sensor i, set by the caller's sheet. */
extern uint8_t host_sensors, host_follow_key;
#define HAL_SENSORS() host_sensors
#define HAL_FOLLOW_KEY() host_follow_key
#define HAL_CRITICAL_BEGIN()
#define HAL_CRITICAL_END()

#endif
