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
;  only off the fast paths, B and DPTR saved only on the paths that use
;  them (a segment load, a level change, a new period), and the commonest
;  cases run straight through: a line at cruise (st_fast), a line on the
;  ramp between level changes (st_rampfast), an arc at cruise or on the
;  ramp (st_arcfast).
;  None of those tests the feed hold: a hold clears their flags
;  (HAL_STEPPER_SLOW, core/stepper.h's STEPPER_HOLD).

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
AR0	= 0x08			; r0, r1, r3 and r7 of bank 1
AR1	= 0x09
AR3	= 0x0b
AR7	= 0x0f
BANK1	= 0x08			; PSW selecting bank 1 (s51 switches banks only on
				; a byte write of PSW, not on setb RS0)
A_0	= 0xe0
A_1	= 0xe1
A_2	= 0xe2
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
;  DWELL_PERIOD, one millisecond in machine cycles: CPU_6T (0 or 1) and
;  RAMP_HI_LEVELS come from the build's clock.s, assembled ahead of this
;  file (firmware/Makefile).
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

;  F's signs, bit 7 of the high bytes of st_lf and st_af: they are linked
;  first after the bits, st_lf at 0x25 and st_af at 0x27 (core/stepper.c),
;  so those bytes, 0x26 and 0x2a, are bit-addressable.
;  tests/test_firmware_asm_equivalence.py checks the addresses in the map.
LF_SIGN	= 0x37			; (0x26 - 0x20) * 8 + 7
AF_SIGN	= 0x57			; (0x2a - 0x20) * 8 + 7

	.globl _stepper_isr, _st_arcfast
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
;  the fast paths' flags, never set with st_load or st_hold
;  (HAL_STEPPER_SLOW clears them where stepper.c sets st_load, and with a
;  hold): st_fast, set while a line cruises and no segment is to be
;  loaded, st_rampfast (see not_fast) and st_arcfast (see arc_fast_set),
;  with st_qpy (the quadrant's move for F >= 0 is a Y move) and st_afinal
;  (the arc's final quadrant), and st_rampup (st_rampfast's choice: climb).
	.area BSEG    (BIT)
_st_fast::
	.ds	1
_st_rampfast::
	.ds	1
_st_arcfast::
	.ds	1
st_qpy:
	.ds	1
st_afinal:
	.ds	1
st_rampup:
	.ds	1
st_xneg:
	.ds	1
st_yneg:
	.ds	1

	.area CSEG    (CODE)

;  An arc's step, both paths: the move (set up by the caller: st_port's
;  direction bit and st_xneg or st_yneg), the coordinate and F.  A move
;  from c to c + 1 adds 2c + 1 to F, one from c to c - 1 takes off
;  2(c - 1) + 1: the 17-bit term 2v + 1 goes to r1:r0 of bank 1 (by address,
;  so the code works in either bank) with its sign in r3, and arc_add adds
;  it or arc_sub takes it off.
;  At cruise (st_arcfast, set by arc_fast_set) the directions are the
;  quadrant's and stay: the fast path enters here from not_fast with
;  neither the port nor the bank touched, and leaves through the tests that
;  can end the fast path, back to the full path.
arc_x:
	setb	_st_pulse_x
	clr	_st_pulse_y
	jnb	st_xneg,1$
	mov	a,(_st_seg + 4)		; to c - 1: the term is of c - 1
	dec	(_st_seg + 4)
	jnz	1$
	dec	(_st_seg + 4) + 1
1$:	mov	a,(_st_seg + 4)
	setb	c
	rlc	a
	mov	AR0,a
	mov	a,(_st_seg + 4) + 1
	rlc	a
	mov	AR1,a
	subb	a,ACC
	mov	AR3,a
	jb	st_xneg,arc_sub
	inc	(_st_seg + 4)		; to c + 1: the term is of c
	mov	a,(_st_seg + 4)
	jnz	arc_add
	inc	(_st_seg + 4) + 1
arc_add:
	mov	a,_st_af
	add	a,AR0
	mov	_st_af,a
	mov	a,_st_af + 1
	addc	a,AR1
	mov	_st_af + 1,a
	mov	a,_st_af + 2
	addc	a,AR3
	mov	_st_af + 2,a
	mov	a,_st_af + 3
	addc	a,AR3
	mov	_st_af + 3,a
	jb	_st_arcfast,af_tail
	ljmp	arc_moved
arc_sub:
	clr	c
	mov	a,_st_af
	subb	a,AR0
	mov	_st_af,a
	mov	a,_st_af + 1
	subb	a,AR1
	mov	_st_af + 1,a
	mov	a,_st_af + 2
	subb	a,AR3
	mov	_st_af + 2,a
	mov	a,_st_af + 3
	subb	a,AR3
	mov	_st_af + 3,a
	jb	_st_arcfast,af_tail
	ljmp	arc_moved
arc_y:
	clr	_st_pulse_x
	setb	_st_pulse_y
	jnb	st_yneg,1$
	mov	a,(_st_seg + 6)
	dec	(_st_seg + 6)
	jnz	1$
	dec	(_st_seg + 6) + 1
1$:	mov	a,(_st_seg + 6)
	setb	c
	rlc	a
	mov	AR0,a
	mov	a,(_st_seg + 6) + 1
	rlc	a
	mov	AR1,a
	subb	a,ACC
	mov	AR3,a
	jb	st_yneg,arc_sub
	inc	(_st_seg + 6)
	mov	a,(_st_seg + 6)
	jnz	arc_add
	inc	(_st_seg + 6) + 1
	sjmp	arc_add
af_tail:
	; The fast path's end tests, those of the full path for the axis that
	; moved: in the final quadrant, has it reached its end coordinate; in
	; another, has the coordinate that ends the quadrant reached 0 (the
	; other axis's moves cannot change it, and arc_fast_set saw it not 0).
	jb	_st_pulse_x,afx_tail
	jb	st_afinal,afy_final
	jb	_st_end_x0,af_cruise
	mov	a,(_st_seg + 6)
	orl	a,(_st_seg + 6) + 1
	jnz	af_cruise
	mov	PSW,#BANK1		; the full path's end test (st_arcfast stays)
	ljmp	arc_y0
afy_final:
	mov	a,(_st_seg + 6)
	cjne	a,(_st_seg + 10),af_cruise
	mov	a,(_st_seg + 6) + 1
	cjne	a,(_st_seg + 10) + 1,af_cruise
	sjmp	af_slow
afx_tail:
	jb	st_afinal,afx_final
	jnb	_st_end_x0,af_cruise
	mov	a,(_st_seg + 4)
	orl	a,(_st_seg + 4) + 1
	jnz	af_cruise
	mov	PSW,#BANK1
	ljmp	arc_x0
afx_final:
	mov	a,(_st_seg + 4)
	cjne	a,(_st_seg + 8),af_cruise
	mov	a,(_st_seg + 4) + 1
	cjne	a,(_st_seg + 8) + 1,af_cruise
af_slow:
	; The full path's tests take over from here, and keep the step's count.
	clr	_st_arcfast
	mov	PSW,#BANK1
	ljmp	arc_moved
af_cruise:
	jnb	_st_cruising,af_ramp
	djnz	_st_cruise_lo,af_exit
	ljmp	cruise_lo_out
af_ramp:
	; On the ramp (set by ramp_ll): the count and the ramp with the choice
	; made, as a line's st_rampfast path does; the last steps (a quadrant's
	; count is an estimate that stops at 1) take the full path.
	mov	a,(_st_seg + 12) + 1
	jnz	1$
	mov	a,(_st_seg + 12)
	add	a,#0xfd
	jnc	af_slow
1$:	ljmp	ramp_counts
af_exit:
	xch	a,AR7
	pop	PSW
	reti

;  The upper bytes of the position at A (pos_x + 1 or pos_y + 1), when the
;  low byte carries or borrows; then back to the pulse.
carry:
	mov	PSW,#BANK1
	mov	r0,a
	inc	@r0
	cjne	@r0,#0,1$
	inc	r0
	inc	@r0
	cjne	@r0,#0,1$
	inc	r0
	inc	@r0
1$:	ljmp	pulse_end
borrow:
	mov	PSW,#BANK1
	mov	r0,a
	dec	@r0
	cjne	@r0,#0xff,1$
	inc	r0
	dec	@r0
	cjne	@r0,#0xff,1$
	inc	r0
	dec	@r0
1$:	ljmp	pulse_end

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
	mov	a,#(_pos_x + 1)
	sjmp	carry
x_minus:
	mov	a,_pos_x
	dec	_pos_x
	jnz	pulse_end
	mov	a,#(_pos_x + 1)
	sjmp	borrow
pulse_not_x:
	jnb	_st_pulse_y,pulse_done
	orl	P1,#Y_STEP
	jb	st_yneg,y_minus
	inc	_pos_y
	mov	a,_pos_y
	jnz	pulse_end
	mov	a,#(_pos_y + 1)
	sjmp	carry
y_minus:
	mov	a,_pos_y
	dec	_pos_y
	jnz	pulse_end
	mov	a,#(_pos_y + 1)
	sjmp	borrow
pulse_end:
	mov	P1,_st_port
pulse_done:
	; st_fast: a line at cruise (nor a segment to load: see below).
	jnb	_st_fast,not_fast
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
	jnb	_st_arcfast,not_arc_fast
	; An arc at cruise (arc_fast_set): F's sign picks the quadrant's move,
	; whose direction st_xneg or st_yneg holds already.
	jb	AF_SIGN,af_neg
	jb	st_qpy,af_y
af_x:
	ljmp	arc_x
af_neg:
	jb	st_qpy,af_x
af_y:
	ljmp	arc_y
not_arc_fast:
	; st_rampfast: a line on the ramp whose last step changed no level.
	; Its brake-or-climb choice stands (steps and brake_at both count down
	; by one a step, the levels stay) until the level's steps run out,
	; and then it is st_rampup's: the level changes (ramp_level).
	jb	_st_rampfast,ramp_fast
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


;  A line step on the ramp with its choice made (st_rampfast): the line
;  step, count, ramp and done of the full path without the choice.
ramp_fast:
line_step:
	; A line step; with st_rampfast (never set on the full path) also its
	; count and ramp, the choice made.
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
	jnb	_st_rampfast,line_full
ramp_counts:				; (an arc's fast path on the ramp too)
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
5$:	mov	a,_st_level_left
	orl	a,_st_level_left + 1
	jz	ramp_level
	mov	a,(_st_seg + 12)
	orl	a,(_st_seg + 12) + 1
	jnz	6$
	setb	_st_load
	clr	_st_rampfast
6$:	xch	a,AR7
	pop	PSW
	reti
line_full:
	jnb	_st_cruising,7$
	ljmp	cruise_step
7$:	ljmp	count
ramp_level:
	; The level's steps have run out: its change, as the full path's ramp
	; would make it (the same choice), straight from here.
	clr	_st_rampfast
	clr	_st_arcfast
	mov	PSW,#BANK1
	mov	c,st_rampup
	mov	F0,c
	ljmp	level_change

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
	; The move r2 (one-hot MV_*): its direction, then the step (arc_x, arc_y).
	mov	a,r2
	jnb	A_0,1$
	anl	_st_port,#~X_DIR
	clr	st_xneg
	ljmp	arc_x
1$:	jnb	A_1,2$
	orl	_st_port,#X_DIR
	setb	st_xneg
	ljmp	arc_x
2$:	jnb	A_2,3$
	anl	_st_port,#~Y_DIR
	clr	st_yneg
	ljmp	arc_y
3$:	orl	_st_port,#Y_DIR
	setb	st_yneg
	ljmp	arc_y
arc_moved:
	mov	P1,_st_port		; direction set a whole period before its pulse
	mov	a,(_st_seg + 15)
	jz	arc_final
	; Has the arc reached the half-axis that ends its quadrant?
	jb	_st_end_x0,arc_endx0
	mov	a,(_st_seg + 6)
	orl	a,(_st_seg + 6) + 1
	jnz	in_quadrant
arc_y0:
	mov	r0,(_st_seg + 4)
	mov	r1,(_st_seg + 4) + 1
	sjmp	arc_endtest
arc_endx0:
	mov	a,(_st_seg + 4)
	orl	a,(_st_seg + 4) + 1
	jnz	in_quadrant
arc_x0:
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
	clr	_st_arcfast		; (the coordinate that ends it is 0: no turn yet)
	jnb	_st_cruising,in_quadrant_count
	ljmp	cruise_step
in_quadrant_count:
	mov	a,(_st_seg + 12) + 1
	jnz	in_quadrant_steps
	mov	a,(_st_seg + 12)
	cjne	a,#1,in_quadrant_steps
turn_ramp:
	ljmp	ramp			; an estimate: the count runs out at the end, not before
in_quadrant_steps:
	ljmp	count
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
	jnb	_st_cruising,in_quadrant_steps
	ljmp	cruise_step

turn_cruise:
	; The turn into the final quadrant (turn_steps), cruising with no hold
	; and more steps left than the braking point: ramp would find the level
	; at cruise and no braking due, and cruise would keep its period and
	; st_cruise_to (the level, the exit and st_brake_at stay while
	; cruising); only the count to the braking point is new.  Straight to
	; it: this spares a third of that interrupt at speed.
	setb	c			; steps - st_cruise_to - 1 < 0: braking is due
	mov	a,(_st_seg + 12)
	subb	a,_st_cruise_to
	mov	a,(_st_seg + 12) + 1
	subb	a,_st_cruise_to + 1
	orl	c,_st_hold
	orl	c,/_st_cruising
	jc	turn_ramp
	ljmp	cruise_set

turn:
	; The arc has crossed into the next quadrant: F0 says whether the step
	; that crossed moved the axis that ended it (else it went through the
	; centre, radius 1), which keeps its direction in the next one.
	mov	c,_st_pulse_x
	jb	_st_end_x0,9$
	cpl	c
9$:	mov	F0,c
	mov	a,(_st_seg + 14)
	lcall	turns_of
	swap	a
	anl	a,#0x07
	mov	(_st_seg + 14),a
	lcall	enter_quadrant
	djnz	(_st_seg + 15),turn_on
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
	sjmp	turn_cruise
turn_on:
	; If the fast path ran, it goes on: F >= 0 moves the other axis, and the
	; axis that did not end the last quadrant is reversed (the quadrants'
	; moves, turn by turn).  Not if the crossing step went through the
	; centre.  (Had it not run, the rest of this cruise takes the full path.)
	jnb	F0,turn_off
	jnb	_st_arcfast,turn_off
	jnb	_st_cruising,turn_off	; on the ramp: ramp_ll sets it up again
	cpl	st_qpy
	jnb	_st_end_x0,2$		; this quadrant ends where x = 0, the last where y = 0
	cpl	st_xneg
	xrl	_st_port,#X_DIR
	sjmp	3$
2$:	cpl	st_yneg
	xrl	_st_port,#Y_DIR
3$:	mov	P1,_st_port
	ljmp	cruise_step
turn_off:
	ljmp	in_quadrant

count:
	; steps--
	mov	a,(_st_seg + 12)
	dec	(_st_seg + 12)
	jnz	ramp
	dec	(_st_seg + 12) + 1
ramp:
	; Brake to the exit level in time, else climb to the cruise level.
	clr	_st_cruising
	clr	_st_fast		; (st_rampfast is never set here)
	clr	_st_arcfast
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
	mov	c,F0			; the choice, for ramp_level
	mov	st_rampup,c
	jb	_st_line,ramp_stale
	jb	_st_stale,ramp_stale	; (not in the long step that loaded the arc)
	lcall	arc_fast_ramp		; an arc: its fast path on the ramp
ramp_stale:
	jnb	_st_stale,done
period_new:
	push	DPL
	push	DPH
	lcall	period_set
	pop	DPH
	pop	DPL
done:
	mov	a,(_st_seg + 12)
	orl	a,(_st_seg + 12) + 1
	jnz	done_exit
	setb	_st_load
	clr	_st_fast
	clr	_st_rampfast
	clr	_st_arcfast
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
	mov	c,_st_line		; the fast paths do not test the hold
	anl	c,/_st_hold
	mov	_st_fast,c
	lcall	arc_fast_set
	sjmp	done

level_change:
	push	Bs
	push	DPL
	push	DPH
	jb	F0,level_up
	; braking: one level down
	dec	_st_level
	dec	_st_level
	lcall	period_set
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
	ljmp	level_done
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
	; level up (its period first); brake_at += level_left;
	; below += level_left; level_left = hold
	inc	_st_level
	inc	_st_level
	lcall	period_set
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
	mov	_st_level_left,r4
	mov	_st_level_left + 1,r5
level_brake_add:
	mov	a,_st_brake_at
	add	a,_st_level_left
	mov	_st_brake_at,a
	mov	a,_st_brake_at + 1
	addc	a,_st_level_left + 1
	mov	_st_brake_at + 1,a
	sjmp	level_done
level_done:
	pop	DPH
	pop	DPL
	pop	Bs
	ljmp	ramp_stale

;  The period of the level into RCAP2, for the overflow that ends this
;  step: before it comes, or the period drifts (level_change calls this as
;  soon as the level is known).  Both bytes in consecutive instructions,
;  so that an overflow between them (a mixed period) is all but ruled out.
;  DPTR saved by the caller; r2 used.
period_set:
	clr	_st_stale
	mov	a,_st_level		; at RAMP_HI_LEVELS and above the high
	add	a,#(0x100 - RAMP_HI_LEVELS)	; byte is not tabled (core/ramp.h)
	mov	a,#0xff
	jc	1$
	mov	dptr,#_ramp_period_hi
	mov	a,_st_level
	movc	a,@a+dptr
1$:	mov	r2,a
	mov	dptr,#_ramp_period_lo
	mov	a,_st_level
	movc	a,@a+dptr
	.if CPU_6T			; twice the table's 12-clock cycles (core/ramp.h)
	add	a,ACC
	xch	a,r2
	rlc	a
	xch	a,r2
	.endif
	mov	RCAP2L,a
	mov	RCAP2H,r2
	ret

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
	add	a,#<_queue		; __pdata: the queue lies in one page (XDATA,
	mov	r1,a			; hal_mcs51.h), the address is its low byte
	mov	r0,#_st_seg
	mov	r3,#(SEG_SIZE / 2)	; two bytes a turn: the load runs into the
load_byte:				; next period, and this is most of it
	movx	a,@r1
	mov	@r0,a
	inc	r1
	inc	r0
	movx	a,@r1
	mov	@r0,a
	inc	r1
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
	clr	_st_cruising		; (the fast paths' flags are never set with st_load)
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

;  st_arcfast, when an arc cruises (or, from arc_fast_ramp, is on the
;  ramp with its choice made: ramp_ll) where the fast path steps as the
;  full one would: in the final quadrant while both moves of the quadrant
;  still head towards the end; in another while the coordinate that ends
;  the quadrant is not 0.  The fast path then keeps the quadrant's
;  directions, set here for both axes and written to the port a whole
;  period before a pulse needs them (unless the pending pulse's axis would
;  change direction: a radius of 1, through the centre).
arc_fast_set:
	clr	_st_arcfast
	mov	c,_st_cruising
	anl	c,/_st_line
	anl	c,/_st_hold
	jnc	afs_ret
arc_fast_ramp:
	mov	a,_st_moves		; both moves: st_moves' two nibbles
	swap	a
	orl	a,_st_moves
	anl	a,#0x0f
	mov	r2,a
	clr	st_afinal
	mov	a,(_st_seg + 15)
	jnz	afs_middle
	setb	st_afinal
	mov	a,r2
	anl	a,(_st_seg + 1)
	xrl	a,r2
	jnz	afs_ret
	sjmp	afs_dirs
afs_middle:
	mov	r0,#(_st_seg + 6)
	jnb	_st_end_x0,1$
	mov	r0,#(_st_seg + 4)
1$:	mov	a,@r0
	inc	r0
	orl	a,@r0
	jz	afs_ret
afs_dirs:
	mov	a,r2			; MV_XN and MV_YN are X_DIR and Y_DIR
	mov	c,A_1
	jnb	_st_pulse_x,2$
	jnb	st_xneg,3$
	cpl	c
3$:	jc	afs_ret
2$:	mov	c,A_3
	jnb	_st_pulse_y,afs_go
	jnb	st_yneg,5$
	cpl	c
5$:	jc	afs_ret
afs_go:					; A: both moves of the quadrant
	mov	c,A_1
	mov	st_xneg,c
	mov	c,A_3
	mov	st_yneg,c
	anl	a,#(X_DIR | Y_DIR)
	xch	a,_st_port
	anl	a,#~(X_DIR | Y_DIR)
	orl	a,_st_port
	mov	_st_port,a
	mov	P1,a
	mov	a,_st_moves		; F >= 0 moves Y
	anl	a,#(MV_YP | MV_YN)
	add	a,#0xff
	mov	st_qpy,c
	setb	_st_arcfast
afs_ret:
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
