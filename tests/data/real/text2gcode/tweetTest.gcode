;=============================
; G-Code generated with Text2G-Code V0.1 
; Created by Salvatore SaXeee Di Benedetto
; Based on <Lawrence Glaister> work "Engrave-lines" 
;=============================
; Plotting text: "#FablaNapoli #MFR16 #IntelMaker #MakeIt10"
; Fontfile: fonts/italict.cxf 
; Line 0 
;=============================
; Coordinata di partenza X: 5.0000
; Coordinata di partenza Y: 110.0000
; Fattore di scala X: 6.0000
; Fattore di scala X: 6.0000
; Angolo: 0.0000
;====================================================
; <Start Preamble> 
G21 ;Set Units to Millimeters
G90 ;Set to Absolute Positioning
G28 ;Move to Origin (Home)
G0 Z0.1000 ;Per compatibilità G-Code viewers
M300 S46
; <End Preamble> 
 
; =================
; | Plotting character '#' |
; =================
 
; <Start travelling> 
M300 S46
G0 X16.6364 Y140.5455
M300 S43
; <End travelling> 
 
G1 X6.4545 Y99.8182 E6.9968
 
; <Start travelling> 
M300 S46
G0 X25.3636 Y140.5455
M300 S43
; <End travelling> 
 
G1 X15.1818 Y99.8182 E6.9968
 
; <Start travelling> 
M300 S46
G0 X6.4545 Y124.5455
M300 S43
; <End travelling> 
 
G1 X26.8182 Y124.5455 E3.3939
 
; <Start travelling> 
M300 S46
G0 X5.0000 Y115.8182
M300 S43
; <End travelling> 
 
G1 X25.3636 Y115.8182 E3.3939

; =================
; | Plotting character 'F' |
; =================
 
; <Start travelling> 
M300 S46
G0 X40.9091 Y140.5455
M300 S43
; <End travelling> 
 
G1 X32.1818 Y110.0000 E5.2946
 
; <Start travelling> 
M300 S46
G0 X42.3636 Y140.5455
M300 S43
; <End travelling> 
 
G1 X33.6364 Y110.0000 E5.2946
 
; <Start travelling> 
M300 S46
G0 X43.8182 Y140.5455
M300 S43
; <End travelling> 
 
G1 X35.0909 Y110.0000 E5.2946
 
; <Start travelling> 
M300 S46
G0 X49.6364 Y131.8182
M300 S43
; <End travelling> 
 
G1 X46.7273 Y120.1818 E1.9991
 
; <Start travelling> 
M300 S46
G0 X36.5455 Y140.5455
M300 S43
; <End travelling> 
 
G1 X58.3636 Y140.5455 E3.6364
 
; <Start travelling> 
M300 S46
G0 X58.3636 Y140.5455
M300 S43
; <End travelling> 
 
G1 X56.9091 Y131.8182 E1.4746
 
; <Start travelling> 
M300 S46
G0 X39.4545 Y126.0000
M300 S43
; <End travelling> 
 
G1 X48.1818 Y126.0000 E1.4545
 
; <Start travelling> 
M300 S46
G0 X27.8182 Y110.0000
M300 S43
; <End travelling> 
 
G1 X39.4545 Y110.0000 E1.9394
 
; <Start travelling> 
M300 S46
G0 X38.0000 Y140.5455
M300 S43
; <End travelling> 
 
G1 X42.3636 Y139.0909 E0.7666
 
; <Start travelling> 
M300 S46
G0 X39.4545 Y140.5455
M300 S43
; <End travelling> 
 
G1 X40.9091 Y137.6364 E0.5421
 
; <Start travelling> 
M300 S46
G0 X45.2727 Y140.5455
M300 S43
; <End travelling> 
 
G1 X42.3636 Y137.6364 E0.6857
 
; <Start travelling> 
M300 S46
G0 X46.7273 Y140.5455
M300 S43
; <End travelling> 
 
G1 X42.3636 Y139.0909 E0.7666
 
; <Start travelling> 
M300 S46
G0 X52.5455 Y140.5455
M300 S43
; <End travelling> 
 
G1 X56.9091 Y139.0909 E0.7666
 
; <Start travelling> 
M300 S46
G0 X54.0000 Y140.5455
M300 S43
; <End travelling> 
 
G1 X56.9091 Y137.6364 E0.6857
 
; <Start travelling> 
M300 S46
G0 X55.4545 Y140.5455
M300 S43
; <End travelling> 
 
G1 X56.9091 Y136.1818 E0.7666
 
; <Start travelling> 
M300 S46
G0 X56.9091 Y140.5455
M300 S43
; <End travelling> 
 
G1 X56.9091 Y131.8182 E1.4545
 
; <Start travelling> 
M300 S46
G0 X49.6364 Y131.8182
M300 S43
; <End travelling> 
 
G1 X46.7273 Y126.0000 E1.0842
 
; <Start travelling> 
M300 S46
G0 X46.7273 Y126.0000
M300 S43
; <End travelling> 
 
G1 X46.7273 Y120.1818 E0.9697
 
; <Start travelling> 
M300 S46
G0 X48.1818 Y128.9091
M300 S43
; <End travelling> 
 
G1 X45.2727 Y126.0000 E0.6857
 
; <Start travelling> 
M300 S46
G0 X45.2727 Y126.0000
M300 S43
; <End travelling> 
 
G1 X46.7273 Y123.0909 E0.5421
 
; <Start travelling> 
M300 S46
G0 X48.1818 Y127.4545
M300 S43
; <End travelling> 
 
G1 X43.8182 Y126.0000 E0.7666
 
; <Start travelling> 
M300 S46
G0 X43.8182 Y126.0000
M300 S43
; <End travelling> 
 
G1 X46.7273 Y124.5455 E0.5421
 
; <Start travelling> 
M300 S46
G0 X33.6364 Y111.4545
M300 S43
; <End travelling> 
 
G1 X29.2727 Y110.0000 E0.7666
 
; <Start travelling> 
M300 S46
G0 X33.6364 Y112.9091
M300 S43
; <End travelling> 
 
G1 X30.7273 Y110.0000 E0.6857
 
; <Start travelling> 
M300 S46
G0 X35.0909 Y112.9091
M300 S43
; <End travelling> 
 
G1 X36.5455 Y110.0000 E0.5421
 
; <Start travelling> 
M300 S46
G0 X33.6364 Y111.4545
M300 S43
; <End travelling> 
 
G1 X38.0000 Y110.0000 E0.7666