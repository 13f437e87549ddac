/* figures.c - see figures.h.  One move per call, so a figure of any length
 * streams through the planner's short queue as a host would send it. */
#include "figures.h"
#include "planner.h"

#ifdef PANEL

XDATA uint8_t fig_next;
typedef char fc_down_is_bit_3[FC_DOWN == 1 << 3 ? 1 : -1];

void figure_move(uint8_t code)
{
    IDATA uint8_t *p = (IDATA uint8_t *)&plan_arg[PLAN_FEED];
    if (code & (FC_UP | FC_DOWN)) planner_pen((uint8_t)(code >> 3) & 1);   /* FC_DOWN is bit 3 */
    do {
        *p++ = 0;                   /* the default feed ($2), and stop at the end */
    } while (p != (IDATA uint8_t *)&plan_arg[PLAN_EXIT + 1]);
    if (code & FC_ARC) planner_arc(code & 1); else planner_line();
}

void figure_poll(void)
{
    IDATA uint16_t *arg = plan_arg;
    uint8_t i, code, n, zero;
    if (queue_used() > QUEUE_SIZE - FIG_QUEUE || !(i = fig_next)) return;
    code = fig_stream[i];
    zero = code;
    n = (uint8_t)((code & FC_ARC) + 2);     /* FC_ARC is 2: 4 numbers, else 2 */
    do {
        *arg = 0;
        if (!(zero & FC_ZERO)) {
            i++;
            *arg = (uint16_t)((int16_t)(int8_t)fig_stream[i] << FIG_GRID_SHIFT);
        }
        arg++;
        zero >>= 1;
    } while (--n);
    i++;
    if (code & FC_END) i = 0;
    fig_next = i;
    figure_move(code);
}

#endif
