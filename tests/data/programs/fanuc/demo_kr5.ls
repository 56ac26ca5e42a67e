/PROG  DEMO_KR5
/ATTR
OWNER		= MNEDITOR;
COMMENT		= "workspace";
PROG_SIZE	= 0;
CREATE		= DATE 26-01-05  TIME 10:00:00;
MODIFIED	= DATE 26-01-05  TIME 10:00:00;
FILE_NAME	= ;
VERSION		= 0;
LINE_COUNT	= 18;
MEMORY_SIZE	= 0;
PROTECT		= READ_WRITE;
TCD:  STACK_SIZE	= 0,
      TASK_PRIORITY	= 50,
      TIME_SLICE	= 0,
      BUSY_LAMP_OFF	= 0,
      ABORT_REQUEST	= 0,
      PAUSE_REQUEST	= 0;
DEFAULT_GROUP	= 1,*,*,*,*;
CONTROL_CODE	= 00000000 00000000;
/MN
   1:  UFRAME_NUM=0 ;
   2:  UTOOL_NUM=0 ;
   3:J P[1] 100% CNT100    ;
   4:L P[2] 500mm/sec CNT100    ;
   5:J P[3] 100% FINE    ;
   6:L P[4] 500mm/sec CNT100    ;
   7:J P[5] 100% CNT100    ;
   8:L P[6] 500mm/sec FINE    ;
   9:J P[7] 100% CNT100    ;
  10:L P[8] 500mm/sec CNT100    ;
  11:J P[9] 100% FINE    ;
  12:L P[10] 500mm/sec CNT100    ;
  13:J P[11] 100% CNT100    ;
  14:L P[12] 500mm/sec FINE    ;
  15:J P[13] 100% CNT100    ;
  16:L P[14] 500mm/sec CNT100    ;
  17:J P[15] 100% FINE    ;
  18:L P[16] 500mm/sec CNT100    ;
/POS
P[1]{
   GP1:
	UF : 0, UT : 0,		CONFIG : 'N U T, 0, 0, 0',
	X =  -217.110  mm,	Y =  -624.107  mm,	Z =  1087.859  mm,
	W =   -40.482 deg,	P =   -30.223 deg,	R =    41.906 deg
};
P[2]{
   GP1:
	UF : 0, UT : 0,		CONFIG : 'N U T, 0, -1, 0',
	X =   395.209  mm,	Y =   -38.193  mm,	Z =  1286.990  mm,
	W =   -76.123 deg,	P =    54.516 deg,	R =  -102.476 deg
};
P[3]{
   GP1:
	UF : 0, UT : 0,		CONFIG : 'N U T, 0, 1, 0',
	X =  1012.784  mm,	Y =  -334.545  mm,	Z =   196.347  mm,
	W =  -132.135 deg,	P =   -26.243 deg,	R =   -18.717 deg
};
P[4]{
   GP1:
	UF : 0, UT : 0,	
	J1=    51.703 deg,	J2=   -92.041 deg,	J3=   -12.531 deg,
	J4=   281.709 deg,	J5=   -44.553 deg,	J6=  -110.678 deg
};
P[5]{
   GP1:
	UF : 0, UT : 0,		CONFIG : 'N U T, 0, 0, 0',
	X =  -298.359  mm,	Y =  1270.477  mm,	Z =   552.564  mm,
	W =  -153.060 deg,	P =    34.500 deg,	R =   170.463 deg
};
P[6]{
   GP1:
	UF : 0, UT : 0,		CONFIG : 'N U T, 0, 1, 0',
	X =    60.341  mm,	Y =   -39.391  mm,	Z =  1381.510  mm,
	W =    77.617 deg,	P =   -26.748 deg,	R =   126.219 deg
};
P[7]{
   GP1:
	UF : 0, UT : 0,		CONFIG : 'F U T, 0, -1, 0',
	X =   -35.947  mm,	Y =   951.332  mm,	Z =  1225.367  mm,
	W =    -7.470 deg,	P =   -41.201 deg,	R =   -44.779 deg
};
P[8]{
   GP1:
	UF : 0, UT : 0,	
	J1=    97.795 deg,	J2=   -95.653 deg,	J3=    69.864 deg,
	J4=   -59.705 deg,	J5=    24.953 deg,	J6=  -180.500 deg
};
P[9]{
   GP1:
	UF : 0, UT : 0,		CONFIG : 'F U T, 0, 0, 1',
	X =   -22.839  mm,	Y =   531.097  mm,	Z =   927.441  mm,
	W =   178.057 deg,	P =   -73.148 deg,	R =   118.171 deg
};
P[10]{
   GP1:
	UF : 0, UT : 0,		CONFIG : 'N D T, 0, 0, -1',
	X =   346.817  mm,	Y =  1354.013  mm,	Z =   327.168  mm,
	W =   -77.626 deg,	P =     4.038 deg,	R =    76.836 deg
};
P[11]{
   GP1:
	UF : 0, UT : 0,		CONFIG : 'F U T, 0, 0, 0',
	X =   633.990  mm,	Y =   689.447  mm,	Z =  1128.155  mm,
	W =   -80.966 deg,	P =    20.735 deg,	R =    -2.315 deg
};
P[12]{
   GP1:
	UF : 0, UT : 0,	
	J1=    72.227 deg,	J2=   -71.019 deg,	J3=    -9.868 deg,
	J4=    16.511 deg,	J5=   -65.144 deg,	J6=   143.548 deg
};
P[13]{
   GP1:
	UF : 0, UT : 0,		CONFIG : 'N U T, 0, 0, 0',
	X =   747.078  mm,	Y =  -419.726  mm,	Z =   602.531  mm,
	W =   124.476 deg,	P =    37.856 deg,	R =   117.001 deg
};
P[14]{
   GP1:
	UF : 0, UT : 0,		CONFIG : 'F U B, 0, 0, -1',
	X =  -199.402  mm,	Y =   -79.419  mm,	Z =  1482.548  mm,
	W =   -50.401 deg,	P =     9.279 deg,	R =  -117.573 deg
};
P[15]{
   GP1:
	UF : 0, UT : 0,		CONFIG : 'N U T, 0, 0, -1',
	X =    58.771  mm,	Y = -1214.486  mm,	Z =   948.081  mm,
	W =    95.454 deg,	P =    -6.237 deg,	R =   -34.494 deg
};
P[16]{
   GP1:
	UF : 0, UT : 0,	
	J1=   131.698 deg,	J2=  -123.088 deg,	J3=    66.260 deg,
	J4=   226.814 deg,	J5=   -98.780 deg,	J6=    52.534 deg
};
/END
