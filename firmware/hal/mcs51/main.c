/* main.c - the STC89C52RC board: timers, UART, interrupts and the main loop.
 * Everything that knows about 8051 registers is here or in hal_mcs51.h. */
#include "../../core/config.h"
#include "../../core/hal.h"
#include "../../core/stepper.h"
#include "../../core/serial.h"
#include "../../core/protocol.h"

static __xdata uint8_t tx_buf[TX_SIZE];
static __data volatile uint8_t tx_head, tx_tail;
static volatile __bit tx_busy;

/* No register bank of its own: it calls nothing, so SDCC saves just the few
 * registers it uses, and bank 2's 8 bytes stay free for data. */
void uart_isr(void) __interrupt(4)
{
    uint8_t c;
    if (RI) {
        RI = 0;
        c = SBUF;
        SERIAL_RX_BYTE(c);
    }
    if (TI) {
        TI = 0;
        if (tx_tail != tx_head) {
            SBUF = tx_buf[tx_tail & (TX_SIZE - 1)];
            tx_tail++;
        } else {
            tx_busy = 0;
        }
    }
}

void hal_putc(uint8_t c)
{
    while ((uint8_t)(tx_head - tx_tail) >= TX_SIZE) {
        /* the transmit interrupt drains the ring; steps go on meanwhile */
    }
    tx_buf[tx_head & (TX_SIZE - 1)] = c;
    tx_head++;
    if (!tx_busy) {
        tx_busy = 1;
        TI = 1;                 /* start the transmit interrupt chain */
    }
}

static void uart_init(void)
{
    SCON = 0x50;                /* mode 1: 8 data bits, receiver on */
#ifdef BAUD_115200
    RCAP2H = 0xFF;              /* Timer 2 as baud generator: 11.0592 MHz / 32 / 3 */
    RCAP2L = 0xFD;
    T2CON = 0x34;               /* RCLK, TCLK, TR2 */
#else
    TMOD = (TMOD & 0x0F) | 0x20;  /* Timer 1 mode 2: 9600 baud */
    TH1 = 0xFD;
    TL1 = 0xFD;
    TR1 = 1;
#endif
    ES = 1;
}

void main(void)
{
    TMOD = (TMOD & 0xF0) | 0x01;  /* Timer 0 mode 1: 16-bit step timer */
    PT0 = 1;                      /* steps preempt the UART */
    ET0 = 1;
    uart_init();
    stepper_init();
    EA = 1;
    protocol_init();
    for (;;) {
        protocol_poll();
    }
}
