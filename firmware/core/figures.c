/* figures.c - see figures.h.  One command per call, so a figure of any
 * length streams through the planner's short queue as a host would send it. */
#include "figures.h"
#include "planner.h"

#ifdef PANEL

FIGURE_ROM uint8_t *XDATA fig_next;

void figure_start(uint8_t fig)
{
    fig_next = &fig_stream[fig_first[fig]];
}

void figure_poll(void)
{
    uint8_t code, n;
    IDATA uint16_t *arg = plan_arg;
    if (!fig_next || !QUEUE_FREE()) return;
    code = *fig_next++;
    if (code >= FC_PEN_UP) {
        planner_pen((uint8_t)(code - FC_PEN_UP));
        return;
    }
    if (code == FC_END) {
        fig_next = 0;
        return;
    }
    for (n = (code == FC_LINE) ? 2 : 4; n; n--) {
        *arg++ = (uint16_t)((int16_t)(int8_t)*fig_next++ << FIG_GRID_SHIFT);
    }
    plan_arg[PLAN_FEED] = 0;        /* the default feed, $2 */
    plan_arg[PLAN_EXIT] = 0;
    if (code == FC_LINE) planner_line(); else planner_arc(code == FC_CW);
}

#endif
