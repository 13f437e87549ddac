;  add8.asm - the line follower's sums (core/hal.h HAL_ADD8): a signed
;  byte added to a little-endian number of n bytes in XRAM (its page, as
;  the image's XDATA), in place of follow.c's C loop, which SDCC spells
;  out in 16-bit arithmetic about three times as long.  The C loop is what
;  the host build runs; the s51 tests hold the board's steering to the
;  host's step for step.
;
;  SDCC's calling convention: the address in DPL; v and n in the
;  functions' shared parameters, in the overlaid segment with the other
;  leaf functions' (no interrupt calls it).

	.module add8
	.optsdcc -mmcs51 --model-small

	.globl _add8, _add8_PARM_2, _add8_PARM_3

ar2	= 0x02			; r2 in the register bank of the main program, bank 0

	.area OSEG    (OVR,DATA)
_add8_PARM_2:
	.ds	1
_add8_PARM_3:
	.ds	1

	.area CSEG    (CODE)

;  *p += v, carried up through n bytes; v's sign extended above its byte.
_add8:
	mov	r0,dpl
	mov	a,_add8_PARM_2
	mov	r2,a			; the byte to add
	rlc	a			; C: v's sign
	subb	a,acc			; 0x00, or 0xFF for v < 0: the bytes above
	mov	r3,a
	mov	r1,_add8_PARM_3
	clr	c
1$:
	movx	a,@r0
	addc	a,r2
	movx	@r0,a
	inc	r0
	mov	ar2,r3			; (mov leaves C, the carry, alone)
	djnz	r1,1$
	ret
