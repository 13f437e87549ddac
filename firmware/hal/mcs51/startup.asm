;  startup.asm - what runs from reset to main(), in place of SDCC's
;  crtstart, crtclear, crtxinit and crtxclear (93 bytes by the map).
;
;  Those are general: a hook for external start-up, a copy of initialised
;  __xdata (this image has none), a clear of __pdata and __xdata of any size
;  and place.  Here the clears cover what the chip has, all of it: the 256
;  bytes of internal RAM and the 256 bytes of on-chip XRAM (which hold
;  __pdata and __xdata, whatever their split), in 15 bytes.  tools/size.py
;  refuses an image with initialised __xdata or more than 256 bytes of
;  XRAM, which this would not set up.  SDCC's own initialisers (area GSINIT)
;  still run after these and before main().
;
;  On the STC89C52RC, MOVX @DPTR below 0x100 reaches the on-chip XRAM while
;  AUXR.EXTRAM is 0, its reset value.

	.module startup
	.optsdcc -mmcs51 --model-small

	.globl __start__stack
	.globl __sdcc_gsinit_startup
	.globl __mcs51_genRAMCLEAR, __mcs51_genXINIT, __mcs51_genXRAMCLEAR

	.area GSINIT0 (CODE)
__sdcc_gsinit_startup:
	mov	sp,#__start__stack - 1

;  The names SDCC's main module asks for, so that the library's are not linked.
	.area GSINIT4 (CODE)
__mcs51_genRAMCLEAR:
__mcs51_genXINIT:
__mcs51_genXRAMCLEAR:
	clr	a
	mov	r0,a			; 256 rounds: 0x00 (r0 itself), then 0xFF down to 0x01
00001$:	mov	@r0,a
	djnz	r0,00001$
	mov	dptr,#0x0000		; r0 is 0 again: 256 more
00002$:	movx	@dptr,a
	inc	dptr
	djnz	r0,00002$
