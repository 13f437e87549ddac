/* main.c - the STC89C52RC board: timers, UART, interrupts and the main loop.
 * Everything that knows about 8051 registers is here or in hal_mcs51.h. */
#include "../../core/config.h"
#include "../../core/hal.h"
#include "../../core/stepper.h"
#include "../../core/serial.h"
#include "../../core/protocol.h"
#include "../../core/panel.h"

static XDATA uint8_t tx_buf[TX_SIZE];
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
    while ((uint8_t)(tx_head - tx_tail) & TX_SIZE) {   /* full: TX_SIZE bytes, never more */
        /* the transmit interrupt drains the ring; steps go on meanwhile */
    }
    tx_buf[tx_head & (TX_SIZE - 1)] = c;
    tx_head++;
    if (!tx_busy) {
        tx_busy = 1;
        TI = 1;                 /* start the transmit interrupt chain */
    }
}

#ifdef PANEL
/* The panel's 1 ms tick, polled by the main loop (no interrupt: the
 * panel's work may wait, the steps may not): Timer 0 where Timer 2 paces
 * the steps, else Timer 2, or Timer 1 when Timer 2 makes the baud rate. */
#define TICK_RELOAD ((uint16_t)(0 - DWELL_PERIOD))   /* 1.0004 ms (922 cycles; 1843 at 6T: 0.9999 ms) */
#if defined(HAL_STEPPER_ISR_EXTERNAL)
#define TICK_INIT()                         /* TR0 in TCON_INIT */
#define TICK_DUE() (TF0 && (TF0 = 0, TH0 = (uint8_t)(TICK_RELOAD >> 8), TL0 = (uint8_t)TICK_RELOAD, 1))
#elif defined(BAUD_115200)
#define TICK_INIT()                         /* TR1 in TCON_INIT */
#define TICK_DUE() (TF1 && (TF1 = 0, TH1 = (uint8_t)(TICK_RELOAD >> 8), TL1 = (uint8_t)TICK_RELOAD, 1))
#else
#define TICK_INIT() (RCAP2H = (uint8_t)(TICK_RELOAD >> 8), RCAP2L = (uint8_t)TICK_RELOAD, TR2 = 1)
#define TICK_DUE() (TF2 && (TF2 = 0, 1))
#endif
#endif

/* The step timer: Timer 2 in 16-bit auto-reload (hal_mcs51.h), or Timer 0
 * in mode 1 (16 bits).  Timer 1 in mode 2 (8-bit auto-reload): the baud
 * rate; with Timer 2 making it, mode 1 for the panel's tick, reloaded by
 * hand. */
#ifdef BAUD_115200
#define TMOD_INIT 0x11
#else
#define TMOD_INIT 0x21
#endif
/* Timer 1 runs (TR1) for the baud rate or the panel's tick; the panel's
 * e-stop (INT0) is edge-triggered (IT0).  They run once EA is set.
 * The board's image: the step timer, the UART and the e-stop share the high
 * level, so none interrupts another, and when one returns the chip takes
 * the pending ones in polling order, INT0, the UART, Timer 2.  A received
 * byte then waits for at most the one interrupt under way, so steps joined
 * at speed (back-to-back segment loads) cannot shut the UART out for a
 * byte time, as a step timer above the UART could; a step waits for at
 * most one UART interrupt (tools/isr_share.py counts both).  The images
 * with the C step interrupt on Timer 0: polling order puts Timer 0 before
 * the UART, so at one level a saturated step timer would still shut it
 * out; there the UART and the e-stop are above the step timer, and the
 * interrupt masks them only while it reloads the timer
 * (HAL_TIMER_ADVANCE). */
#if defined(HAL_STEPPER_ISR_EXTERNAL)
#define TCON_INIT 0x51              /* TR1, TR0 (the tick), IT0 */
#define IP_INIT   0x31              /* PT2, PS, PX0 */
#define IE_INIT   0x31              /* ET2, ES, EX0 */
#elif defined(PANEL)
#define TCON_INIT 0x41              /* TR1, IT0 */
#define IP_INIT   0x11              /* PS, PX0 */
#define IE_INIT   0x13              /* ES, ET0, EX0 */
#else
#ifdef BAUD_115200
#define TCON_INIT 0x00
#else
#define TCON_INIT 0x40
#endif
#define IP_INIT   0x10              /* PS */
#define IE_INIT   0x12
#endif

#ifdef PANEL
/* The e-stop button: its falling edge stops the pulses at once, the main
 * loop raises the alarm (and keeps raising it while the button is held). */
void estop_isr(void) __interrupt(0)
{
    RT_STOP(rt_estop);
}

/* Rounds of the wait below: a round takes twice as many cycles at 6T. */
#ifdef CPU_6T
#define LCD_WAIT 40
#else
#define LCD_WAIT 20
#endif

/* After HAL_LCD_WRITE has set RS. */
void hal_lcd_write(uint8_t b)
{
    uint8_t n = LCD_WAIT;
    P0 = b;
    P3 |= LCD_E;                /* one machine cycle high: 1.09 us (0.54 at 6T), the LCD needs 0.23 */
    P3 &= (uint8_t)~LCD_E;      /* the LCD takes the byte on this edge */
    while (--n) {
        /* 40 us for the LCD to carry it out (R/W is tied low: no busy flag) */
    }
}

/* The bit number of the one zero bit of a nibble; 0xFF if none or several. */
static const __code uint8_t zero_bit[16] = {
    0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 0xFF, 3,
    0xFF, 0xFF, 0xFF, 2, 0xFF, 1, 0, 0xFF,
};

/* Line reversal (seed 000, 3.1.1): rows low, read the columns; columns
 * low, read the rows.  Row * 4 + column; 0xFC or more (K_NONE or above)
 * when either has no zero bit or several. */
uint8_t hal_key_scan(void)
{
    uint8_t col, row;
    P2 = 0xF0;
    col = zero_bit[P2 >> 4];
    P2 = 0x0F;
    row = zero_bit[(uint8_t)(P2 & 0x0F)];
    P2 = 0xFF;
    return (uint8_t)((row << 2) | col);
}
#endif

/* Timer 1's reload for 9600 baud: a bit is 32 overflows, so 3 cycles an
 * overflow at 921,600 machine cycles/s, 6 at 1,843,200 (6T). */
#ifdef CPU_6T
#define BAUD_RELOAD 0xFA
#else
#define BAUD_RELOAD 0xFD
#endif

void main(void)
{
    TMOD = TMOD_INIT;
    SCON = 0x50;                  /* UART mode 1: 8 data bits, receiver on */
#ifdef BAUD_115200
    RCAP2H = 0xFF;                /* Timer 2 as baud generator: 11.0592 MHz / 32 / 3 */
    RCAP2L = 0xFD;
    T2CON = 0x34;                 /* RCLK, TCLK, TR2 */
#else
    TH1 = BAUD_RELOAD;            /* 9600 baud */
    TL1 = BAUD_RELOAD;
#endif
    TCON = TCON_INIT;
    IP = IP_INIT;
    IE = IE_INIT;
    stepper_init();
#ifdef PANEL
    TICK_INIT();
    panel_init();
#endif
    EA = 1;
    protocol_init();
    for (;;) {
        protocol_poll();
#ifdef PANEL
        if (TICK_DUE()) {
            panel_tick();
        }
#endif
    }
}
