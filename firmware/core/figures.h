/* figures.h - the panel's built-in figures: command streams in ROM
 * (tools/gen_figures.py makes them from the host's own shapes) and the
 * player that queues them one move at a time. */
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

/* A stream is a sequence of moves, each a code byte and its numbers:
 * signed bytes, in units of 2^FIG_GRID_SHIFT steps (tools/gen_figures.py,
 * GRID).  The code byte also carries the pen change before the move and
 * which of the first three numbers are 0 (not stored). */
#define FIG_GRID_SHIFT 5
#define FC_LINE     0x00    /* dx dy */
#define FC_ARC      0x02    /* dx dy i j: FC_CCW, or FC_CW */
#define FC_CCW      0x02
#define FC_CW       0x03
#define FC_UP       0x04    /* pen up before the move */
#define FC_DOWN     0x08    /* pen down before the move */
#define FC_END      0x10    /* the last move of the figure */
#define FC_ZERO     0x20    /* << k, k = 0..2: number k is 0, left out of the stream */
#define FIG_QUEUE   2       /* queue slots a move takes at most: the pen, the move */

#define FIGURE_ROM const ROM
/* The index in fig_stream of each figure's first move (fig_stream[FIG_*]),
 * then the moves; fewer than 256 bytes. */
extern FIGURE_ROM uint8_t fig_stream[];

/* The index of the next move of the figure being drawn; 0 when none is. */
extern XDATA uint8_t fig_next;
#define FIGURE_PLAYING() (fig_next != 0)

#define FIGURE_START(fig) (fig_next = fig_stream[fig])     /* fig: FIG_* */
void figure_poll(void);         /* queue the next move if there is room */
/* Queue the move of plan_arg (a line: dx dy; an arc: dx dy i j) at the
 * default feed, after the pen change of `code` (FC_*). */
void figure_move(uint8_t code);

#endif
