/* figures.h - the panel's built-in figures: command streams in ROM
 * (tools/gen_figures.py makes them from the host's own shapes) and the
 * player that queues them one command at a time. */
#ifndef FIGURES_H
#define FIGURES_H

#include "config.h"
#include "hal.h"

#define FIG_DIAMOND 0
#define FIG_STAR    1
#define FIG_CONE    2
#define FIG_CAR     3
#define FIG_CAR_REV 4
#define FIGURES     5

/* Command codes of the streams, each followed by its arguments: signed
 * bytes, in units of 2^FIG_GRID_SHIFT steps (tools/gen_figures.py, GRID). */
#define FIG_GRID_SHIFT 5
#define FC_END      0
#define FC_LINE     1   /* dx dy */
#define FC_CW       2   /* dx dy i j */
#define FC_CCW      3
#define FC_PEN_UP   4
#define FC_PEN_DOWN 5

#define FIGURE_ROM const ROM
extern FIGURE_ROM uint8_t fig_stream[];
extern FIGURE_ROM uint8_t fig_first[FIGURES];    /* where each figure's stream starts */

/* The next command of the figure being drawn; 0 when none is. */
extern FIGURE_ROM uint8_t *XDATA fig_next;
#define FIGURE_PLAYING() (fig_next != 0)

void figure_start(uint8_t fig);
void figure_poll(void);         /* queue the next command if there is room */

#endif
