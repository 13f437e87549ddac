/* protocol.h - the command line protocol of firmware/PROTOCOL.md: assembles
 * received bytes into lines, checks sequence numbers and checksums, executes
 * commands, and answers with ok / err / rs / status reports. */
#ifndef PROTOCOL_H
#define PROTOCOL_H

#include "config.h"
#include "hal.h"

extern uint8_t alarm_code;     /* 0 = no alarm; see ALARM_* */
#define ALARM_ESTOP 1
#define ALARM_LIMIT 2

void protocol_init(void);      /* print the start-up banner */
void protocol_poll(void);      /* one pass of the main loop */
/* Stop at once: pulses, queue, hold and figure; alarm_code = code, and
 * "[<alarm_text>]" to the host.  Code 0 is a reset: no alarm. */
void protocol_alarm(uint8_t code);
const ROM char *alarm_text(void);  /* "alarm estop", "alarm limit", or "reset" without an alarm */
#ifdef PANEL
void protocol_lcd(const ROM char *text);   /* rewrite the LCD: position, then text */
void protocol_segments(uint16_t v);        /* v, 0..9999, on the 7-segment display as 4 digits */
#endif

#endif
