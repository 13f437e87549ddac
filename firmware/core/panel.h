/* panel.h - the board's own front panel (seed 000, chapters 3-4): the 4x4
 * keypad and its functions, numeric entry on the 7-segment display, the
 * prompts on the LCD, and the built-in figures the keys start.  In the
 * board's image (PANEL, defined by the Makefile); the option images drive
 * other machines and use its pins for their windings or Z axis. */
#ifndef PANEL_H
#define PANEL_H

#include "config.h"
#include "hal.h"

#ifdef PANEL
/* Key codes as the keypad reports them: row * 4 + column (rows P2.0-P2.3,
 * columns P2.4-P2.7, firmware/README.md); the functions of seed 000,
 * figure 3.2. */
#define K_RESET   0     /* clear / reset */
#define K_XP      1
#define K_CONE    2
#define K_CIRCLE  3
#define K_DIAG    4     /* X and Y together, equal speed */
#define K_XN      5
#define K_DIAMOND 6
#define K_STAR    7
#define K_FASTER  8
#define K_YP      9
#define K_CAR     11
#define K_SLOWER  12
#define K_YN      13
#define K_PAUSE   14    /* pause / resume (a feed hold); the seed has it on the reset key */
#define K_CAR_REV 15
#define KEYS      16    /* HAL_KEY_SCAN: no key (or several) is K_NONE or another code above */
#define K_NONE    0xFF

extern XDATA uint8_t panel_segments[4];     /* the 7-segment display's right four digits, lit segments */
extern FAST uint8_t panel_prompt;           /* the LCD's second line: its offset in the prompts (panel_text) */
const ROM char *panel_text(void);           /* that line: the prompt, or the alarm */

void panel_init(void);
void panel_tick(void);      /* every millisecond, from the main loop */
void panel_stop(void);      /* after a reset or an alarm: back to the menu */
#define PANEL_BUSY() FIGURE_PLAYING()
#include "figures.h"

extern XDATA uint8_t lcd_t;     /* display.c: ticks since power-up, then since the last refresh */
#define DISPLAY_INIT() (lcd_t = 0)      /* the LCD's start-up sequence from the next tick */
void display_tick(void);        /* one LCD byte and one 7-segment digit */
#else
#define PANEL_BUSY() 0
#endif

#endif
