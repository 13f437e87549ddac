(Exported by FreeCAD)
(Post Processor: grbl_post)
(Output Time:2023-08-10 17:49:00.417800)
(Begin preamble)
G17 G90
G21
(Block-name: G54)
(Block-expand: 0)
(Block-enable: 1)
(Begin operation: G54)
(Path: G54)
G54
G0 Z5.000
(Finish operation: G54)
(Block-name: 33mm Endmill003)
(Block-expand: 0)
(Block-enable: 1)
(Begin operation: 33mm Endmill003)
(Path: 33mm Endmill003)
(33mm Endmill003)
(Begin toolchange)
( M6 T2 )
(Finish operation: 33mm Endmill003)
(Block-name: Profile015)
(Block-expand: 0)
(Block-enable: 1)
(Begin operation: Profile015)
(Path: Profile015)
(Profile015)
(Compensated Tool Path. Diameter: 33.0)
G0 Z5.000
G0 X16.244 Y16.240
G0 Z3.000
G1 X16.244 Y16.240 Z-11.000 F100.000
G2 X22.973 Y0.251 Z-11.000 I-16.246 J-16.247 K0.000 F200.000
G1 X22.951 Y-0.887 Z-11.000 F200.000
G2 X-22.972 Y0.570 Z-11.000 I-22.956 J0.893 K0.000 F200.000
G2 X16.244 Y16.240 Z-11.000 I22.969 J-0.577 K0.000 F200.000
G0 Z5.000
G0 Z5.000
(Finish operation: Profile015)
(Block-name: G54)
(Block-expand: 0)
(Block-enable: 1)
(Begin operation: G54)
(Path: G54)
G54
G0 Z5.000
(Finish operation: G54)
(Block-name: 33mm Endmill003)
(Block-expand: 0)
(Block-enable: 1)
(Begin operation: 33mm Endmill003)
(Path: 33mm Endmill003)
(33mm Endmill003)
(Begin toolchange)
( M6 T2 )
(Finish operation: 33mm Endmill003)
(Block-name: Profile016)
(Block-expand: 0)
(Block-enable: 1)
(Begin operation: Profile016)
(Path: Profile016)
(Profile016)
(Compensated Tool Path. Diameter: 33.0)
G0 Z5.000
G0 X15.533 Y15.533
G0 Z3.000
G1 X15.533 Y15.533 Z-11.000 F100.000
G2 X21.912 Y1.556 Z-11.000 I-15.538 J-15.536 K0.000 F200.000
G2 X19.201 Y-10.674 Z-11.000 I-21.756 J-1.593 K0.000 F200.000
G2 X-21.949 Y-1.118 Z-11.000 I-19.205 J10.680 K0.000 F200.000
G2 X15.533 Y15.533 Z-11.000 I21.944 J1.116 K0.000 F200.000
G0 Z5.000
G0 Z5.000
(Finish operation: Profile016)
(Block-name: G54)
(Block-expand: 0)
(Block-enable: 1)
(Begin operation: G54)
(Path: G54)
G54
G0 Z5.000
(Finish operation: G54)
(Block-name: 33mm Endmill003)
(Block-expand: 0)
(Block-enable: 1)
(Begin operation: 33mm Endmill003)
(Path: 33mm Endmill003)
(33mm Endmill003)
(Begin toolchange)
( M6 T2 )
(Finish operation: 33mm Endmill003)
(Block-name: Profile017)
(Block-expand: 0)
(Block-enable: 1)
(Begin operation: Profile017)
(Path: Profile017)
(Profile017)
(Compensated Tool Path. Diameter: 33.0)
G0 Z5.000
G0 X14.825 Y14.827
G0 Z3.000
G1 X14.825 Y14.827 Z-11.000 F100.000
G2 X20.954 Y-0.780 Z-11.000 I-14.831 J-14.831 K0.000 F200.000
G1 X20.916 Y-1.484 Z-11.000 F200.000
G2 X-20.946 Y1.183 Z-11.000 I-20.921 J1.491 K0.000 F200.000
G2 X14.825 Y14.827 Z-11.000 I20.940 J-1.187 K0.000 F200.000
G0 Z5.000
G0 Z5.000
(Finish operation: Profile017)
(Block-name: G54)
(Block-expand: 0)
(Block-enable: 1)
(Begin operation: G54)
(Path: G54)
G54
G0 Z5.000
(Finish operation: G54)
(Block-name: 33mm Endmill003)
(Block-expand: 0)
(Block-enable: 1)
(Begin operation: 33mm Endmill003)
(Path: 33mm Endmill003)
(33mm Endmill003)
(Begin toolchange)
( M6 T2 )
(Finish operation: 33mm Endmill003)
(Block-name: Profile018)
(Block-expand: 0)
(Block-enable: 1)
(Begin operation: Profile018)
(Path: Profile018)
(Profile018)
(Compensated Tool Path. Diameter: 33.0)
G0 Z5.000
G0 X14.118 Y14.120
G0 Z3.000
G1 X14.118 Y14.120 Z-11.000 F100.000
G2 X19.955 Y-0.726 Z-11.000 I-14.124 J-14.124 K0.000 F200.000
G1 X19.917 Y-1.430 Z-11.000 F200.000
G2 X-19.947 Y1.144 Z-11.000 I-19.923 J1.437 K0.000 F200.000
G2 X14.118 Y14.120 Z-11.000 I19.941 J-1.148 K0.000 F200.000
G0 Z5.000
G0 Z5.000
(Finish operation: Profile018)
(Block-name: G54)
(Block-expand: 0)
(Block-enable: 1)
(Begin operation: G54)
(Path: G54)
G54
G0 Z5.000
(Finish operation: G54)
(Block-name: 33mm Endmill003)
(Block-expand: 0)
(Block-enable: 1)
(Begin operation: 33mm Endmill003)
(Path: 33mm Endmill003)
(33mm Endmill003)
(Begin toolchange)
( M6 T2 )
(Finish operation: 33mm Endmill003)
(Block-name: Profile019)
(Block-expand: 0)
(Block-enable: 1)
(Begin operation: Profile019)
(Path: Profile019)
(Profile019)
(Compensated Tool Path. Diameter: 33.0)
G0 Z5.000
G0 X13.411 Y13.413
G0 Z3.000
G1 X13.411 Y13.413 Z-11.000 F100.000
G2 X18.957 Y-0.673 Z-11.000 I-13.417 J-13.417 K0.000 F200.000
G1 X18.919 Y-1.377 Z-11.000 F200.000
G2 X-18.948 Y1.105 Z-11.000 I-18.924 J1.384 K0.000 F200.000
G2 X13.411 Y13.413 Z-11.000 I18.942 J-1.109 K0.000 F200.000
G0 Z5.000
G0 Z5.000
(Finish operation: Profile019)
(Block-name: post_amble)
(Block-expand: 0)
(Block-enable: 1)
(Begin postamble)
M5
G17 G90
M2
