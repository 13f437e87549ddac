/* figures.c - see figures.h.  One move per call, so a figure of any length
 * streams through the planner's short queue as a host would send it. */
#include "figures.h"
#include "planner.h"

#ifdef PANEL

FIGURE_ROM uint8_t *XDATA fig_next;

void figure_start(uint8_t fig)
{
    fig_next = &fig_stream[fig_first[fig]];
}

void figure_move(uint8_t code)
{
    if (code & FC_UP) planner_pen(0);
    plan_arg[PLAN_FEED] = 0;        /* the default feed, $2 */
    plan_arg[PLAN_EXIT] = 0;
    if (code & FC_ARC) planner_arc(code & 1); else planner_line();
    if (code & FC_DOWN) planner_pen(1);
}

void figure_poll(void)
{
    FIGURE_ROM uint8_t *p = fig_next;
    IDATA uint16_t *arg = plan_arg;
    uint8_t code, n;
    if (!p || queue_used() > QUEUE_SIZE - FIG_QUEUE) return;
    code = *p++;
    n = (uint8_t)((code & FC_ARC) + 2);     /* FC_ARC is 2: 4 numbers, else 2 */
    do {
        *arg++ = (uint16_t)((int16_t)(int8_t)*p++ << FIG_GRID_SHIFT);
    } while (--n);
    if (code & FC_END) p = 0;
    fig_next = p;
    figure_move(code);
}

#endif
