/* display.c - the panel's displays, refreshed from the panel tick so that
 * neither ever holds up the steps (seed 000, 3.3.1: refresh every few timer
 * periods):
 *   the 8-digit common-cathode 7-segment display, multiplexed one digit per
 *   tick: the right four show panel_segments, the left four stay dark;
 *   the LCD (HD44780, 16x2, written only): initialised one command per tick
 *   after power-up, then rewritten every LCD_PERIOD ticks by the protocol's
 *   number printing (protocol_lcd): line 1 the live X and Y in steps, line 2
 *   the prompt or the alarm. */
#include "panel.h"
#include "protocol.h"

#ifdef PANEL

/* From tick LCD_BOOT (> 15 ms after power-up): 8-bit bus, two lines (three
 * times, the first 4 ms before the others), display on without cursor,
 * cursor moving right, clear (which takes 1.6 ms). */
#define LCD_BOOT 20
static const ROM uint8_t lcd_init[12] = {0x38, 0, 0, 0, 0, 0x38, 0x38, 0x0C, 0x06, 0x01, 0, 0};
#define LCD_READY (LCD_BOOT + sizeof lcd_init)
#define LCD_PERIOD 96               /* ms: about ten refreshes a second */

/* Ticks since power-up, then LCD_READY + ticks since the last refresh.
 * LCD_READY and LCD_PERIOD are multiples of 8, so its low 3 bits count
 * on without a break: they pick the 7-segment digit. */
XDATA uint8_t lcd_t;
typedef char lcd_t_counts_the_digit[(LCD_READY % 8 == 0 && LCD_PERIOD % 8 == 0) ? 1 : -1];

void display_tick(void)
{
    uint8_t c, t = lcd_t;
    if (t < LCD_READY) {
        lcd_t = (uint8_t)(t + 1);
        c = (uint8_t)(t - LCD_BOOT);            /* wraps before LCD_BOOT */
        if (c < sizeof lcd_init && (c = lcd_init[c]) != 0) {
            HAL_LCD_WRITE(c, 0);
        }
    } else if (++t == LCD_READY + LCD_PERIOD) {
        lcd_t = LCD_READY;
        protocol_lcd(panel_text());
    } else {
        lcd_t = t;
    }
    t = (uint8_t)(lcd_t & 7);
    c = 0;
    if (t & 4) c = panel_segments[(uint8_t)(t & 3)];
    HAL_SEG_SHOW(t, c);
}

#endif
