/* config.h - build-time sizes and constants shared by the core and both HALs. */
#ifndef CONFIG_H
#define CONFIG_H

#include <stdint.h>

#define FW_NAME     "PLOTTER 8051"
#define FW_VERSION  "1.0"

/* STC89C52RC at 11.0592 MHz, 12 clocks per machine cycle. */
#define CYCLES_PER_S  921600UL
#define DWELL_PERIOD  922u          /* one millisecond in machine cycles */

#define QUEUE_SIZE  6               /* motion segments buffered ahead */
#define RX_SIZE     64              /* UART receive ring (power of two) */
#define TX_SIZE     16              /* UART transmit ring (power of two) */
#define LINE_MAX    48              /* longest accepted command line, without newline */

/* Real-time bytes acted on by the receive interrupt, never queued. */
#define RT_STATUS  '?'
#define RT_HOLD    '!'
#define RT_RESUME  '~'
#define RT_RESET   0x18             /* Ctrl-X */
#define RT_ESTOP   0x1B             /* ESC */

/* Output bits of the step/direction port (P1 on the 8051 board). */
#define BIT_X_STEP  0x01
#define BIT_X_DIR   0x02            /* set: moving towards -X */
#define BIT_Y_STEP  0x04
#define BIT_Y_DIR   0x08            /* set: moving towards -Y */
#define BIT_PEN     0x10            /* set: pen down */
#define STEP_BITS   (BIT_X_STEP | BIT_Y_STEP)

#endif
