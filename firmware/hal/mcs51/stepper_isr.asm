;  stepper_isr.asm - the step interrupt of the board's image (PANEL, point-by-
;  point comparison, step/direction, Timer 2 in 16-bit auto-reload), by hand.
;
;  The logic is core/stepper.c's ISR, label for label (run, cruise_step,
;  not_line, count, ramp, done, load, pause, cruise, turn): the host build,
;  the mock board and the tests run that C, and
;  tests/test_firmware_asm_equivalence.py holds this code to it step for
;  step in s51.  The state is stepper.c's (shared through
;  HAL_STEPPER_ISR_EXTERNAL), the period lives in RCAP2 (HAL_STEP_PERIOD).
;
;  What makes it fast: no reload instructions (auto-reload), A parked in
;  bank 1's r7 instead of pushed, bank 1 selected for scratch registers
;  only off the cruising line's path, B and DPTR saved only on the paths
;  that use them (a segment load, a level change, a new period), and the
;  commonest cases - a line at cruise (st_fast), a line on the ramp between
;  level changes (st_rampfast) - run straight through.  Arcs take the
;  path of the C, transcribed.

	.module stepper_isr
	.optsdcc -mmcs51 --model-small

;  SFRs and bits
P1	= 0x90
PSW	= 0xd0
ACC	= 0xe0
Bs	= 0xf0
DPL	= 0x82
DPH	= 0x83
RCAP2L	= 0xca
RCAP2H	= 0xcb
TF2	= 0xcf
TR2	= 0xca
LIM_X	= 0x95			; P1.5, X limit at -X, closed = 0
LIM_Y	= 0x97			; P1.7, Y limit at -Y
F0	= 0xd5			; PSW.5, restored on exit
AR7	= 0x0f			; r7 of bank 1
BANK1	= 0x08			; PSW selecting bank 1 (s51 switches banks only on
				; a byte write of PSW, not on setb RS0)
A_0	= 0xe0
A_1	= 0xe1
A_3	= 0xe3
A_7	= 0xe7

;  core/config.h, core/segment.h, core/ramp.h
X_STEP	= 0x01
X_DIR	= 0x02
Y_STEP	= 0x04
Y_DIR	= 0x08
PEN	= 0x10
MV_XP	= 0x01
MV_XN	= 0x02
MV_YP	= 0x04
MV_YN	= 0x08
SEG_LINE = 1
SEG_PEN	= 4
SEG_DWELL = 5
QUEUE_SLOTS = 7
;  DWELL_PERIOD, one millisecond in machine cycles: CPU_6T is set (0 or 1)
;  by the build's clock.s, assembled ahead of this file (firmware/Makefile).
	.if CPU_6T
DWELL_P	= 1843
	.else
DWELL_P	= 922
	.endif

;  segment_t (core/segment.h)
;  kind       _st_seg + 0
;  dirs       _st_seg + 1
;  a          _st_seg + 4
;  b          _st_seg + 6
;  c          _st_seg + 8
;  d          _st_seg + 10
;  steps      _st_seg + 12
;  quad       _st_seg + 14
;  cross      _st_seg + 15
;  cruise     _st_seg + 16
;  exit       _st_seg + 17
;  cper       _st_seg + 18
;  ebrake     _st_seg + 20
SEG_SIZE = 22

;  F's sign, bit 7 of st_lf's high byte: st_lf is linked at 0x2d (after
;  pos_x and pos_y, core/stepper.c), so that byte, 0x2e, is bit-addressable.
;  tests/test_firmware_asm_equivalence.py checks the address in the map.
LF_SIGN	= 0x77			; (0x2e - 0x20) * 8 + 7

	.globl _stepper_isr
	.globl _pos_x, _pos_y, _st_seg, _st_port, _st_level, _st_underruns
	.globl _st_hold, _st_running, _st_paused, _rt_limit
	.globl _st_lf, _st_af, _st_moves, _st_level_left, _st_below, _st_brake_at
	.globl _st_cruise_to, _st_cruise_lo, _st_cruise_hi
	.globl _st_pulse_x, _st_pulse_y, _st_load, _st_line, _st_cruising
	.globl _st_stale, _st_end_x0, _st_end_neg
	.globl _q_head, _q_tail, _queue, _setting
	.globl _ramp_hold, _ramp_period_lo, _ramp_period_hi

;  Bank 1 is the interrupt's: r7 keeps the interrupted code's A.
	.area REG_BANK_1	(REL,OVR,DATA)
	.ds 8

;  st_port's direction bits as flags, for the pulse's position count; and
;  st_fast, set while a line cruises and no segment is to be loaded, and
;  st_rampfast (see not_fast): never with st_load (HAL_STEPPER_ABORT clears
;  them where stepper.c sets st_load).
	.area BSEG    (BIT)
_st_fast::
	.ds	1
_st_rampfast::
	.ds	1
st_xneg:
	.ds	1
st_yneg:
	.ds	1

	.area CSEG    (CODE)

;  Rare cases of the code below, placed before it so that its branches
;  reach them.
limit_x:
	mov	a,_st_port
	jb	A_1,limit_stop
	jb	LIM_Y,no_limit
limit_y:
	mov	a,_st_port
	jnb	A_3,no_limit
limit_stop:
	clr	TR2
	clr	TF2
	setb	_rt_limit
	ljmp	exit

_stepper_isr:
	push	PSW
	xch	a,AR7			; the interrupted code's A waits in bank 1's r7
	clr	TF2
	; A closed limit switch at the end the machine heads for: no more pulses.
	jnb	LIM_X,limit_x
	jnb	LIM_Y,limit_y
no_limit:
	; The step computed by the previous interrupt, its pulse high while the
	; position counts (st_xneg, st_yneg: st_port's direction bits).
	jnb	_st_pulse_x,pulse_not_x
	orl	P1,#X_STEP
	jb	st_xneg,x_minus
	inc	_pos_x
	mov	a,_pos_x
	jnz	pulse_end
	mov	PSW,#BANK1
	mov	r0,#(_pos_x + 1)
	lcall	carry
	sjmp	pulse_end
x_minus:
	mov	a,_pos_x
	dec	_pos_x
	jnz	pulse_end
	mov	PSW,#BANK1
	mov	r0,#(_pos_x + 1)
	lcall	borrow
	sjmp	pulse_end
pulse_not_x:
	jnb	_st_pulse_y,pulse_done
	orl	P1,#Y_STEP
	jb	st_yneg,y_minus
	inc	_pos_y
	mov	a,_pos_y
	jnz	pulse_end
	mov	PSW,#BANK1
	mov	r0,#(_pos_y + 1)
	lcall	carry
	sjmp	pulse_end
y_minus:
	mov	a,_pos_y
	dec	_pos_y
	jnz	pulse_end
	mov	PSW,#BANK1
	mov	r0,#(_pos_y + 1)
	lcall	borrow
pulse_end:
	mov	P1,_st_port
pulse_done:
	; st_fast: a line at cruise (nor a segment to load: see below).
	jnb	_st_fast,not_fast
	jb	_st_hold,run_holding
	; Line: F >= 0 steps X and adds -|dy| (negated at the load), F < 0
	; steps Y and adds |dx| (line_step below, in full).
	jb	LF_SIGN,line_y
	setb	_st_pulse_x
	clr	_st_pulse_y
	mov	a,_st_lf
	add	a,(_st_seg + 6)
	mov	_st_lf,a
	mov	a,_st_lf + 1
	addc	a,(_st_seg + 6) + 1
	mov	_st_lf + 1,a
	; The distance to the braking point counts down, one djnz (and no
	; hold: st_hold cannot change during the interrupt).
	djnz	_st_cruise_lo,exit
	sjmp	cruise_lo_out
line_y:
	clr	_st_pulse_x
	setb	_st_pulse_y
	mov	a,_st_lf
	add	a,(_st_seg + 4)
	mov	_st_lf,a
	mov	a,_st_lf + 1
	addc	a,(_st_seg + 4) + 1
	mov	_st_lf + 1,a
	djnz	_st_cruise_lo,exit
	sjmp	cruise_lo_out
not_fast:
	; st_rampfast: a line on the ramp whose last step changed no level.
	; Its brake-or-climb choice stands (steps and brake_at both count down
	; by one a step, the levels and the hold stay) until the level's
	; steps run out: then, or in a hold, the full path.
	jnb	_st_rampfast,not_ramp_fast
	jb	_st_hold,not_ramp_fast
	mov	a,_st_level_left + 1
	jnz	ramp_fast
	mov	a,_st_level_left
	add	a,#0xfe
	jc	ramp_fast
not_ramp_fast:
	clr	_st_rampfast
	mov	PSW,#BANK1
	jb	_st_load,load
run:
	jb	_st_hold,run_holding
	jnb	_st_line,not_line
	ljmp	line_step
cruise_step:
	djnz	_st_cruise_lo,cruise_go
cruise_lo_out:
	mov	PSW,#BANK1
	mov	a,_st_cruise_hi
	jz	cruise_out_near
	dec	_st_cruise_hi
cruise_go:
	jb	_st_hold,cruise_held_near
exit:
	xch	a,AR7
	pop	PSW
	reti
cruise_out_near:
	ljmp	cruise_out
load:
	ljmp	load_seg
not_line:
	ljmp	not_line_far
run_holding:
	ljmp	run_holding_far
cruise_held_near:
	ljmp	cruise_held

;  The upper bytes of the position at r0, when the low byte carries or borrows.
carry:
	inc	@r0
	cjne	@r0,#0,1$
	inc	r0
	inc	@r0
	cjne	@r0,#0,1$
	inc	r0
	inc	@r0
1$:	ret
borrow:
	dec	@r0
	cjne	@r0,#0xff,1$
	inc	r0
	dec	@r0
	cjne	@r0,#0xff,1$
	inc	r0
	dec	@r0
1$:	ret

;  A line step on the ramp with its choice made (st_rampfast): the line
;  step, count, ramp and done of the full path without the choice.
ramp_fast:
line_step:
	; A line step; with st_rampfast (cleared on the way to the full path)
	; also its count and ramp, the choice made.
	jb	LF_SIGN,1$
	setb	_st_pulse_x
	clr	_st_pulse_y
	mov	a,_st_lf
	add	a,(_st_seg + 6)
	mov	_st_lf,a
	mov	a,_st_lf + 1
	addc	a,(_st_seg + 6) + 1
	sjmp	2$
1$:	clr	_st_pulse_x
	setb	_st_pulse_y
	mov	a,_st_lf
	add	a,(_st_seg + 4)
	mov	_st_lf,a
	mov	a,_st_lf + 1
	addc	a,(_st_seg + 4) + 1
2$:	mov	_st_lf + 1,a
	jnb	_st_rampfast,8$
	mov	a,(_st_seg + 12)
	dec	(_st_seg + 12)
	jnz	3$
	dec	(_st_seg + 12) + 1
3$:	mov	a,_st_brake_at
	dec	_st_brake_at
	jnz	4$
	dec	_st_brake_at + 1
4$:	mov	a,_st_level_left
	dec	_st_level_left
	jnz	5$
	dec	_st_level_left + 1
5$:	mov	a,(_st_seg + 12)
	orl	a,(_st_seg + 12) + 1
	jnz	6$
	setb	_st_load
	clr	_st_rampfast
6$:	xch	a,AR7
	pop	PSW
	reti
8$:	jnb	_st_cruising,7$
	ljmp	cruise_step
7$:	ljmp	count

run_holding_far:
	mov	PSW,#BANK1
	; A feed hold at the start rate stops here (a dwell runs its time out).
	mov	a,_st_level
	add	a,#0xfe
	jc	run_held
	mov	a,(_st_seg + 0)
	cjne	a,#SEG_DWELL,pause
run_held:
	jb	_st_line,line_step
	sjmp	not_line_far
pause:
	clr	TR2
	clr	TF2
	setb	_st_paused
	clr	_st_pulse_x
	clr	_st_pulse_y
	ljmp	exit

cruise_out:
	mov	(_st_seg + 12),_st_cruise_to
	mov	(_st_seg + 12) + 1,_st_cruise_to + 1
	sjmp	cruise_end
cruise_held:
	; steps = cruise_to + 256 * cruise_hi + (uint8_t)(cruise_lo - 1) + 1
	mov	a,_st_cruise_lo
	dec	a
	add	a,#1
	mov	r0,a
	clr	a
	addc	a,_st_cruise_hi
	mov	r1,a
	mov	a,r0
	add	a,_st_cruise_to
	mov	(_st_seg + 12),a
	mov	a,r1
	addc	a,_st_cruise_to + 1
	mov	(_st_seg + 12) + 1,a
cruise_end:
	; An arc's estimate runs out at its end, not before.
	jb	_st_line,1$
	mov	a,(_st_seg + 15)
	jz	1$
	mov	a,(_st_seg + 12)
	orl	a,(_st_seg + 12) + 1
	jnz	1$
	mov	(_st_seg + 12),#1
1$:	ljmp	ramp

not_line_far:
	mov	a,(_st_seg + 0)
	cjne	a,#SEG_DWELL,arc
	; A dwell (also a pen's settle time) counts milliseconds.
	mov	RCAP2L,#<(-DWELL_P)
	mov	RCAP2H,#>(-DWELL_P)
	mov	a,(_st_seg + 12)
	dec	(_st_seg + 12)
	jnz	dwell_done
	dec	(_st_seg + 12) + 1
dwell_done:
	ljmp	done

arc:
	; Arc: the move F's sign picks (st_moves: F >= 0 low nibble, F < 0 high).
	mov	a,_st_af + 3
	jnb	A_7,arc_fpos
	mov	a,_st_moves
	swap	a
	sjmp	arc_fmv
arc_fpos:
	mov	a,_st_moves
arc_fmv:
	anl	a,#0x0f
	mov	r2,a
	mov	a,(_st_seg + 15)
	jnz	arc_go
	; Final quadrant: never pass the end.
	mov	a,r2
	anl	a,(_st_seg + 1)
	jnz	arc_go
	mov	a,_st_moves		; the other move, if it heads towards the end
	swap	a
	orl	a,_st_moves
	anl	a,(_st_seg + 1)
	mov	r2,a
	jnz	arc_go
	mov	a,(_st_seg + 1)		; off the staircase: straight onto it, X first
	anl	a,#(MV_XP | MV_XN)
	mov	r2,a
	jnz	arc_go
	mov	r2,(_st_seg + 1)
arc_go:
	; r1:r0 = c, the coordinate before a + move, minus it before a - move
	mov	a,r2
	anl	a,#(MV_XP | MV_XN)
	jz	arc_y
	setb	_st_pulse_x
	clr	_st_pulse_y
	mov	a,r2
	anl	a,#(MV_XN | MV_YN)
	jz	arc_xp
	mov	a,(_st_seg + 4)
	add	a,#0xff
	mov	(_st_seg + 4),a
	cpl	a
	mov	r0,a
	mov	a,(_st_seg + 4) + 1
	addc	a,#0xff
	mov	(_st_seg + 4) + 1,a
	cpl	a
	mov	r1,a
	orl	_st_port,#X_DIR
	setb	st_xneg
	sjmp	arc_f
arc_xp:
	mov	r0,(_st_seg + 4)
	mov	r1,(_st_seg + 4) + 1
	inc	(_st_seg + 4)
	mov	a,(_st_seg + 4)
	jnz	arc_xp1
	inc	(_st_seg + 4) + 1
arc_xp1:
	anl	_st_port,#~X_DIR
	clr	st_xneg
	sjmp	arc_f
arc_y:
	clr	_st_pulse_x
	setb	_st_pulse_y
	mov	a,r2
	anl	a,#(MV_XN | MV_YN)
	jz	arc_yp
	mov	a,(_st_seg + 6)
	add	a,#0xff
	mov	(_st_seg + 6),a
	cpl	a
	mov	r0,a
	mov	a,(_st_seg + 6) + 1
	addc	a,#0xff
	mov	(_st_seg + 6) + 1,a
	cpl	a
	mov	r1,a
	orl	_st_port,#Y_DIR
	setb	st_yneg
	sjmp	arc_f
arc_yp:
	mov	r0,(_st_seg + 6)
	mov	r1,(_st_seg + 6) + 1
	inc	(_st_seg + 6)
	mov	a,(_st_seg + 6)
	jnz	arc_yp1
	inc	(_st_seg + 6) + 1
arc_yp1:
	anl	_st_port,#~Y_DIR
	clr	st_yneg
arc_f:
	; F += 2c + 1, c sign-extended to 32 bits
	mov	a,r0
	setb	c
	rlc	a
	mov	r0,a
	mov	a,r1
	rlc	a
	mov	r1,a
	subb	a,ACC			; 0 - sign
	mov	r3,a
	mov	a,_st_af
	add	a,r0
	mov	_st_af,a
	mov	a,_st_af + 1
	addc	a,r1
	mov	_st_af + 1,a
	mov	a,_st_af + 2
	addc	a,r3
	mov	_st_af + 2,a
	mov	a,_st_af + 3
	addc	a,r3
	mov	_st_af + 3,a
	mov	P1,_st_port		; direction set a whole period before its pulse
	mov	a,(_st_seg + 15)
	jz	arc_final
	; Has the arc reached the half-axis that ends its quadrant?
	jb	_st_end_x0,arc_endx0
	mov	a,(_st_seg + 6)
	orl	a,(_st_seg + 6) + 1
	jnz	in_quadrant
	mov	r0,(_st_seg + 4)
	mov	r1,(_st_seg + 4) + 1
	sjmp	arc_endtest
arc_endx0:
	mov	a,(_st_seg + 4)
	orl	a,(_st_seg + 4) + 1
	jnz	in_quadrant
	mov	r0,(_st_seg + 6)
	mov	r1,(_st_seg + 6) + 1
arc_endtest:
	mov	a,r0
	orl	a,r1
	jz	in_quadrant
	mov	a,r1
	jb	A_7,arc_endneg
	jnb	_st_end_neg,turn
	sjmp	in_quadrant
arc_endneg:
	jb	_st_end_neg,turn
in_quadrant:
	jnb	_st_cruising,in_quadrant_count
	ljmp	cruise_step
in_quadrant_count:
	mov	a,(_st_seg + 12) + 1
	jnz	1$
	mov	a,(_st_seg + 12)
	cjne	a,#1,1$
	sjmp	ramp			; an estimate: the count runs out at the end, not before
1$:	ljmp	count
arc_final:
	; An axis that reached its end coordinate moves no more.
	jnb	_st_pulse_x,arc_final_y
	mov	a,(_st_seg + 4)
	cjne	a,(_st_seg + 8),arc_final_done
	mov	a,(_st_seg + 4) + 1
	cjne	a,(_st_seg + 8) + 1,arc_final_done
	anl	(_st_seg + 1),#~(MV_XP | MV_XN)
	sjmp	arc_final_done
arc_final_y:
	mov	a,(_st_seg + 6)
	cjne	a,(_st_seg + 10),arc_final_done
	mov	a,(_st_seg + 6) + 1
	cjne	a,(_st_seg + 10) + 1,arc_final_done
	anl	(_st_seg + 1),#~(MV_YP | MV_YN)
arc_final_done:
	jnb	_st_cruising,count
	ljmp	cruise_step

turn:
	; The arc has crossed into the next quadrant.
	mov	a,(_st_seg + 14)
	lcall	turns_of
	swap	a
	anl	a,#0x07
	mov	(_st_seg + 14),a
	lcall	enter_quadrant
	djnz	(_st_seg + 15),in_quadrant
	; Final quadrant: the remaining count is now exact, and the moves
	; towards the end are known.
	mov	r0,#(_st_seg + 8)
	mov	r1,#(_st_seg + 4)
	lcall	end_diff		; c - a
	mov	r6,#0
	jc	1$
	jz	2$
	mov	r6,#MV_XP
	sjmp	2$
1$:	mov	r6,#MV_XN
2$:	mov	a,r2
	mov	r4,a
	mov	a,r3
	mov	r5,a
	mov	r0,#(_st_seg + 10)
	mov	r1,#(_st_seg + 6)
	lcall	end_diff		; d - b
	jc	3$
	jz	turn_steps
	mov	a,#MV_YP
	sjmp	4$
3$:	mov	a,#MV_YN
4$:	orl	a,r6
	mov	r6,a
turn_steps:
	mov	a,r4
	add	a,r2
	mov	(_st_seg + 12),a
	mov	a,r5
	addc	a,r3
	mov	(_st_seg + 12) + 1,a
	mov	(_st_seg + 1),r6
	sjmp	ramp

count:
	; steps--
	mov	a,(_st_seg + 12)
	dec	(_st_seg + 12)
	jnz	ramp
	dec	(_st_seg + 12) + 1
ramp:
	; Brake to the exit level in time, else climb to the cruise level.
	clr	_st_cruising
	clr	_st_fast
	clr	_st_rampfast
	mov	a,_st_level
	add	a,#0xfe
	jnc	ramp_not_brake		; level 0: never brakes
	jb	_st_hold,ramp_brake
	mov	a,(_st_seg + 16)
	clr	c
	subb	a,_st_level		; cruise < level
	jc	ramp_brake
	mov	a,(_st_seg + 17)
	clr	c
	subb	a,_st_level		; exit < level ...
	jnc	ramp_not_brake
	clr	c			; ... and steps <= brake_at
	mov	a,_st_brake_at
	subb	a,(_st_seg + 12)
	mov	a,_st_brake_at + 1
	subb	a,(_st_seg + 12) + 1
	jnc	ramp_brake
ramp_not_brake:
	mov	a,_st_level
	clr	c
	subb	a,(_st_seg + 16)
	jnc	cruise			; level >= cruise
	jb	_st_hold,cruise
	setb	F0			; climb
	sjmp	ramp_count
ramp_brake:
	clr	F0
ramp_count:
	; brake_at--, and the level's steps
	mov	a,_st_brake_at
	dec	_st_brake_at
	jnz	ramp_bd
	dec	_st_brake_at + 1
ramp_bd:
	mov	a,_st_level_left
	dec	_st_level_left
	jnz	ramp_ll
	dec	_st_level_left + 1
ramp_ll:
	mov	a,_st_level_left
	orl	a,_st_level_left + 1
	jz	level_change
	jb	_st_hold,ramp_stale
	mov	c,_st_line
	mov	_st_rampfast,c
ramp_stale:
	jnb	_st_stale,done
period_new:
	clr	_st_stale
	push	DPL
	push	DPH
	mov	dptr,#_ramp_period_lo
	mov	a,_st_level
	movc	a,@a+dptr
	mov	RCAP2L,a
	mov	dptr,#_ramp_period_hi
	mov	a,_st_level
	movc	a,@a+dptr
	mov	RCAP2H,a
	pop	DPH
	pop	DPL
done:
	mov	a,(_st_seg + 12)
	orl	a,(_st_seg + 12) + 1
	jnz	done_exit
	setb	_st_load
	clr	_st_fast
	clr	_st_rampfast
done_exit:
	ljmp	exit

cruise:
	; Cruise at the commanded feed until the braking point (never, if the
	; exit level is not below this one).
	mov	RCAP2L,(_st_seg + 18)
	mov	RCAP2H,(_st_seg + 18) + 1
	setb	_st_stale
	clr	a
	mov	_st_cruise_to,a
	mov	_st_cruise_to + 1,a
	mov	a,(_st_seg + 17)
	clr	c
	subb	a,_st_level
	jnc	cruise_set
	mov	_st_cruise_to,_st_brake_at
	mov	_st_cruise_to + 1,_st_brake_at + 1
cruise_set:
	; hold = steps - cruise_to; hi = (hold - 1) >> 8, lo = (uint8_t)hold
	clr	c
	mov	a,(_st_seg + 12)
	subb	a,_st_cruise_to
	mov	_st_cruise_lo,a
	mov	r0,a
	mov	a,(_st_seg + 12) + 1
	subb	a,_st_cruise_to + 1
	mov	r1,a
	mov	a,r0
	add	a,#0xff
	mov	a,r1
	addc	a,#0xff
	mov	_st_cruise_hi,a
	setb	_st_cruising
	mov	c,_st_line
	mov	_st_fast,c
	sjmp	done

;  hold steps of level A: ramp_hold[A] * setting[SET_ACCEL] into r1:r0
;  (B and DPTR saved by the caller)
hold_steps:
	mov	dptr,#_ramp_hold
	movc	a,@a+dptr
	mov	r1,#_setting
	mov	b,@r1
	mul	ab
	mov	r0,a
	mov	r1,b
	ret

level_change:
	push	Bs
	push	DPL
	push	DPH
	jb	F0,level_up
	; braking: one level down
	dec	_st_level
	dec	_st_level
	mov	a,_st_level
	lcall	hold_steps
	mov	_st_level_left,r0
	mov	_st_level_left + 1,r1
	mov	r1,#_st_below		; below -= level_left
	clr	c
	mov	a,@r1
	subb	a,r0
	mov	@r1,a
	inc	r1
	mov	a,@r1
	subb	a,_st_level_left + 1
	mov	@r1,a
	ljmp	level_stale
level_up:
	mov	a,_st_level
	lcall	hold_steps
	mov	_st_level_left,r0
	mov	_st_level_left + 1,r1
	mov	a,_st_level
	add	a,#2
	lcall	hold_steps		; r5:r4 = hold of the next level
	mov	a,r0
	mov	r4,a
	mov	a,r1
	mov	r5,a
	; climb if level < exit or steps >= brake_at + level_left + hold (mod 2^16)
	mov	a,_st_level
	clr	c
	subb	a,(_st_seg + 17)
	jc	level_climb
	mov	a,_st_brake_at
	add	a,_st_level_left
	mov	r2,a
	mov	a,_st_brake_at + 1
	addc	a,_st_level_left + 1
	mov	r3,a
	mov	a,r2
	add	a,r4
	mov	r2,a
	mov	a,r3
	addc	a,r5
	mov	r3,a
	clr	c
	mov	a,(_st_seg + 12)
	subb	a,r2
	mov	a,(_st_seg + 12) + 1
	subb	a,r3
	jnc	level_climb
	; steps <= brake_at: brake at once
	clr	c
	mov	a,_st_brake_at
	subb	a,(_st_seg + 12)
	mov	a,_st_brake_at + 1
	subb	a,(_st_seg + 12) + 1
	jc	level_stay
	mov	_st_level_left,#1
	mov	_st_level_left + 1,#0
	sjmp	level_brake_add
level_stay:
	; stay only while braking still arrives: min(level_left, steps - brake_at)
	clr	c
	mov	a,(_st_seg + 12)
	subb	a,_st_brake_at
	mov	r2,a
	mov	a,(_st_seg + 12) + 1
	subb	a,_st_brake_at + 1
	mov	r3,a
	clr	c
	mov	a,r2
	subb	a,_st_level_left
	mov	a,r3
	subb	a,_st_level_left + 1
	jnc	level_brake_add
	mov	_st_level_left,r2
	mov	_st_level_left + 1,r3
	sjmp	level_brake_add
level_climb:
	; brake_at += level_left; below += level_left; level up; level_left = hold
	mov	a,_st_brake_at
	add	a,_st_level_left
	mov	_st_brake_at,a
	mov	a,_st_brake_at + 1
	addc	a,_st_level_left + 1
	mov	_st_brake_at + 1,a
	mov	r0,#_st_below
	mov	a,@r0
	add	a,_st_level_left
	mov	@r0,a
	inc	r0
	mov	a,@r0
	addc	a,_st_level_left + 1
	mov	@r0,a
	inc	_st_level
	inc	_st_level
	mov	_st_level_left,r4
	mov	_st_level_left + 1,r5
	setb	_st_stale
level_brake_add:
	mov	a,_st_brake_at
	add	a,_st_level_left
	mov	_st_brake_at,a
	mov	a,_st_brake_at + 1
	addc	a,_st_level_left + 1
	mov	_st_brake_at + 1,a
	sjmp	level_done
level_stale:
	setb	_st_stale
level_done:
	pop	DPH
	pop	DPL
	pop	Bs
	ljmp	ramp_stale

load_seg:
	; Copy the next queued segment into st_seg and prepare it.
	clr	_st_pulse_x
	clr	_st_pulse_y
	mov	a,_q_tail
	cjne	a,_q_head,load_copy
	clr	TR2			; the queue is empty: stop
	clr	TF2
	mov	_st_level,#0
	clr	_st_running
	ljmp	exit
load_copy:
	mov	r2,a			; the slot
	push	Bs
	push	DPL
	push	DPH
	mov	Bs,#SEG_SIZE
	mul	ab
	add	a,#<_queue
	mov	DPL,a
	mov	a,Bs
	addc	a,#>_queue
	mov	DPH,a
	mov	r0,#_st_seg
	mov	r3,#SEG_SIZE
load_byte:
	movx	a,@dptr
	mov	@r0,a
	inc	dptr
	inc	r0
	djnz	r3,load_byte
	clr	_st_line
	mov	a,(_st_seg + 0)
	cjne	a,#SEG_LINE,load_not_line
	setb	_st_line
	clr	a
	mov	_st_lf,a
	mov	_st_lf + 1,a
	mov	a,(_st_seg + 4)
	orl	a,(_st_seg + 4) + 1
	jnz	load_line_dirs
	mov	_st_lf,#0xff		; a pure Y move must never take the F >= 0 branch
	mov	_st_lf + 1,#0xff
load_line_dirs:
	mov	a,_st_port
	anl	a,#~(X_DIR | Y_DIR)
	orl	a,(_st_seg + 1)
	mov	_st_port,a
	mov	c,A_1
	mov	st_xneg,c
	mov	c,A_3
	mov	st_yneg,c
	clr	c			; the line adds -|dy| where the C takes |dy| off
	clr	a
	subb	a,(_st_seg + 6)
	mov	(_st_seg + 6),a
	clr	a
	subb	a,(_st_seg + 6) + 1
	mov	(_st_seg + 6) + 1,a
	sjmp	load_queue
load_not_line:
	add	a,#(0x100 - SEG_PEN)
	jnc	load_arc
	mov	a,(_st_seg + 0)
	cjne	a,#SEG_PEN,load_dwell
	mov	a,_st_port
	anl	a,#~PEN
	orl	a,(_st_seg + 1)
	mov	_st_port,a
load_dwell:
	mov	(_st_seg + 0),#SEG_DWELL
	anl	_st_level,#1
	mov	r0,#_st_below
	clr	a
	mov	@r0,a
	inc	r0
	mov	@r0,a
	mov	a,_st_level
	lcall	hold_steps
	mov	_st_level_left,r0
	mov	_st_level_left + 1,r1
	sjmp	load_queue
load_arc:
	clr	a
	mov	_st_af,a
	mov	_st_af + 1,a
	mov	_st_af + 2,a
	mov	_st_af + 3,a
	lcall	enter_quadrant
load_queue:
	mov	a,r2
	inc	a
	cjne	a,#QUEUE_SLOTS,load_tail
	clr	a
load_tail:
	mov	_q_tail,a
	mov	r4,(_st_seg + 20)
	mov	r5,(_st_seg + 20) + 1
	mov	r3,a
	mov	a,(_st_seg + 17)
	add	a,#0xfe
	jnc	load_brake
	mov	a,r3
	cjne	a,_q_head,load_brake
	; Nothing follows yet: plan to stop rather than run off the queue's end.
	anl	(_st_seg + 17),#1
	mov	r4,#0
	mov	r5,#0
	mov	r0,#_st_underruns
	inc	@r0
	cjne	@r0,#0,load_brake
	inc	r0
	inc	@r0
load_brake:
	; brake_at = below - brake + level_left
	mov	r0,#_st_below
	clr	c
	mov	a,@r0
	subb	a,r4
	mov	r4,a
	inc	r0
	mov	a,@r0
	subb	a,r5
	mov	r5,a
	mov	a,r4
	add	a,_st_level_left
	mov	_st_brake_at,a
	mov	a,r5
	addc	a,_st_level_left + 1
	mov	_st_brake_at + 1,a
	clr	_st_cruising
	clr	_st_fast
	clr	_st_rampfast
	setb	_st_stale
	pop	DPH
	pop	DPL
	pop	Bs
	mov	P1,_st_port		; directions and pen settle a whole period before the pulse
	mov	a,(_st_seg + 12)
	orl	a,(_st_seg + 12) + 1
	jnz	load_run
	mov	RCAP2L,#<(-64)		; empty segment: look again shortly
	mov	RCAP2H,#>(-64)
	ljmp	exit
load_run:
	clr	_st_load
	ljmp	run

;  r3:r2 = |(@r0) - (@r1)|, of two words in internal RAM whose difference
;  fits in 16 bits; C set if it is negative, else A = 0 if it is zero.
end_diff:
	clr	c
	mov	a,@r0
	subb	a,@r1
	mov	r2,a
	inc	r0
	inc	r1
	mov	a,@r0
	subb	a,@r1
	mov	r3,a
	jnb	A_7,1$
	clr	c
	clr	a
	subb	a,r2
	mov	r2,a
	clr	a
	subb	a,r3
	mov	r3,a
	setb	c
	ret
1$:	orl	a,r2
	clr	c
	ret

;  An arc enters quadrant st_seg.quadrant: its moves and its end.
enter_quadrant:
	mov	a,(_st_seg + 14)
	lcall	moves_of
	mov	_st_moves,a
	mov	a,(_st_seg + 14)
	lcall	turns_of
	mov	c,A_0
	mov	_st_end_x0,c
	mov	c,A_1
	mov	_st_end_neg,c
	ret

;  Per quadrant index (4 if clockwise, plus quadrant I..IV = 0..3): the move
;  for F >= 0 in the low nibble, for F < 0 in the high (seed 000 table 2.2).
moves_of:
	inc	a
	movc	a,@a+pc
	ret
	.db	0x42, 0x28, 0x81, 0x14, 0x18, 0x41, 0x24, 0x82
;  The half-axis that ends the quadrant (+X, +Y, -X, -Y = 0..3) in bits 0-1,
;  the index of the quadrant after it in bits 4-6.
turns_of:
	inc	a
	movc	a,@a+pc
	ret
	.db	0x11, 0x22, 0x33, 0x00, 0x70, 0x41, 0x52, 0x63
