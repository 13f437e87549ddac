/* serial.c - storage of the receive ring shared by the UART interrupt and the
 * protocol (see serial.h). */
#include "serial.h"

XDATA uint8_t rx_buf[RX_SIZE];
FAST volatile uint8_t rx_head, rx_tail;
FAST volatile uint8_t rx_flush_to;
volatile FLAG rx_overflow;
volatile FLAG rx_between_lines = 1;
volatile FLAG rx_arm_a, rx_arm_b;
volatile FLAG rt_status, rt_resume, rt_estop, rt_reset, rt_limit;
