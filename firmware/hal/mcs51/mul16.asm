;  mul16.asm - the planner's 16 x 16 -> 32-bit products (core/hal.h
;  HAL_MUL16U, HAL_MUL16S), by four MUL AB, in place of SDCC's 32 x 32
;  _mullong, which those products were all the image linked it for.
;
;  SDCC's calling convention: a in DPL, DPH; b in the functions' shared
;  second parameter, in the overlaid segment with the planner's other leaf
;  functions' (they never run at the same time, and no interrupt calls
;  these), so it needs no RAM of its own; the product in DPL, DPH, B, A.  On the host the C expressions of hal_host.h stand for
;  these; the board's arcs, planned with them, are held to the host's step
;  for step by the s51 tests.

	.module mul16
	.optsdcc -mmcs51 --model-small

A_7	= 0xe7

	.globl _mul16u, _mul16s, _mul16u_PARM_2, _mul16s_PARM_2

	.area OSEG    (OVR,DATA)
_mul16u_PARM_2:
_mul16s_PARM_2:
	.ds	2

	.area CSEG    (CODE)

;  Unsigned a * b; leaves a in r5:r4, b in r3:r2 and the product in
;  r7:r6:r1:r0 for _mul16s.
_mul16u:
	mov	r4,dpl
	mov	r5,dph
	mov	r2,_mul16u_PARM_2
	mov	r3,_mul16u_PARM_2 + 1
	mov	b,r2			; a_lo * b_lo
	mov	a,r4
	mul	ab
	mov	r0,a
	mov	r1,b
	mov	b,r3			; a_hi * b_hi
	mov	a,r5
	mul	ab
	mov	r6,a
	mov	r7,b
	mov	b,r3			; a_lo * b_hi
	mov	a,r4
	mul	ab
	lcall	cross
	mov	b,r2			; a_hi * b_lo
	mov	a,r5
	mul	ab
	lcall	cross
product:
	mov	dpl,r0
	mov	dph,r1
	mov	b,r6
	mov	a,r7
	ret
;  r7:r6:r1 += B:A, a middle term
cross:
	add	a,r1
	mov	r1,a
	mov	a,b
	addc	a,r6
	mov	r6,a
	clr	a
	addc	a,r7
	mov	r7,a
	ret

;  Signed a * b: the unsigned product, less b * 2^16 if a < 0 and less
;  a * 2^16 if b < 0 (modulo 2^32).
_mul16s:
	lcall	_mul16u
	mov	a,r5
	jnb	A_7,1$
	clr	c
	mov	a,r6
	subb	a,r2
	mov	r6,a
	mov	a,r7
	subb	a,r3
	mov	r7,a
1$:	mov	a,r3
	jnb	A_7,product
	clr	c
	mov	a,r6
	subb	a,r4
	mov	r6,a
	mov	a,r7
	subb	a,r5
	mov	r7,a
	sjmp	product
