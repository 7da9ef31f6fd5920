#!/usr/bin/env python3
# The design of lenses/toroidal-anamorphic.50mm.zmx (written for lensim): paraxial x and y traces
# (2x2 matrices on y and n u) of a front attachment of two toroidal singlets (F2, N-FK5) before the
# double Gauss of lenses/dgauss.50mm.dat (its indices replaced by the nearest Schott glasses,
# as `lensim lens info lenses:dgauss.50mm --glass-match` picks them). x section: a Galilean
# wide-angle attachment (f -40 mm, then +80 mm, symmetric in x: radii of rotation +-2 (n-1) f);
# y section: weak menisci (radius 120 mm). The air gap is solved so that the x section is afocal,
# the last y radius so that the y section is afocal too: both sections then focus on the prime's
# focal plane (BFL_x = BFL_y). Run it to rewrite the .zmx next to it.
import math
import os
prime=[(29.475,3.76,1.67003),(84.83,0.12,1),(19.275,4.025,1.67003),(40.77,3.275,1.69892),(12.75,5.705,1),(0,4.5,1),
(-14.495,1.18,1.60311),(40.77,6.065,1.65844),(-20.385,0.19,1),(437.065,3.22,1.71736),(-39.73,0,1)]
nbk7=1.5168  # (the first design; unused now)
# Element A in F2, element B in N-FK5: a Galilean attachment stays afocal across wavelengths
# when V_B / V_A = (1 - d phi_A) / (1 - d phi_B) * (-phi_B / phi_A) = 2 here; F2 and N-FK5 give 1.94.
nA, nB = 1.620040, 1.487490
def trace(surfs, sec):
    # surfs: list of dict(cy, cx, t, n); returns system ABCD (y,nu)
    n=1.0; A,B,C,D=1,0,0,1
    M=[[1,0],[0,1]]
    for s in surfs:
        c = s['cy'] if sec=='y' else s['cx']
        n2=s['n']
        P=(n2-n)*c
        R=[[1,0],[-P,1]]
        M=[[R[0][0]*M[0][0]+R[0][1]*M[1][0], R[0][0]*M[0][1]+R[0][1]*M[1][1]],[R[1][0]*M[0][0]+R[1][1]*M[1][0], R[1][0]*M[0][1]+R[1][1]*M[1][1]]]
        T=[[1,s['t']/n2],[0,1]]
        M=[[T[0][0]*M[0][0]+T[0][1]*M[1][0], T[0][0]*M[0][1]+T[0][1]*M[1][1]],[M[1][0],M[1][1]]]
        n=n2
    return M
def lens(p):
    Rx1,Rx2,Rx3,Rx4,Ry,Ry4,sep,gap=p
    att=[dict(cy=1/Ry,cx=1/Rx1,t=2.5,n=nA),dict(cy=1/Ry,cx=1/Rx2,t=sep,n=1),
         dict(cy=1/Ry,cx=1/Rx3,t=6.0,n=nB),dict(cy=1/Ry4,cx=1/Rx4,t=gap,n=1)]
    pr=[dict(cy=(1/r if r else 0),cx=(1/r if r else 0),t=t,n=n) for r,t,n in prime]
    return att+pr, att
def afocal_err(att,sec):
    M=trace(att,sec); return M[1][0]
# x: f_A=-40 biconcave, f_B=+80 biconvex
RA=2*(nA-1)*40; RB=2*(nB-1)*80
Ry=120.0
def solve(param_index, p, sec, lo, hi):
    # bisection on afocal error
    def f(v):
        q=list(p); q[param_index]=v; return afocal_err(lens(q)[1],sec)
    a,b=lo,hi; fa=f(a)
    for _ in range(200):
        m=0.5*(a+b); fm=f(m)
        if (fm<0)==(fa<0): a,fa=m,fm
        else: b=m
    return 0.5*(a+b)
p=[-RA,RA,RB,-RB,Ry,Ry,38.0,8.0]
for it in range(5):
    p[6]=solve(6,p,'x',20,60)
    p[5]=solve(5,p,'y',60,400)
print('params',p)
surfs,att=lens(p)
for sec in 'xy':
    M=trace(surfs,sec)
    efl=-1/M[1][0]; bfl=-M[0][0]/M[1][0]
    Ma=trace(att,sec)
    print(sec,'EFL',efl,'BFL',bfl,'att C',Ma[1][0],'att mag',Ma[1][1])

# ---- write the .zmx
glass_prime={1.67003:('N-BAF10',1.670030,47.11),1.69892:('N-SF15',1.698920,30.20),1.60311:('N-SK14',1.603110,60.60),1.65844:('N-SSK5',1.658440,50.88),1.71736:('N-SF1',1.717360,29.62)}
pdiam=[25.2,25.2,23,23,18,17.1,17,20,20,20,20]
Rx1,Rx2,Rx3,Rx4,Ry,Ry4,sep,gap=p
out=[]
w=out.append
w('VERS 160608 48 100027')
w('MODE SEQ')
w('NAME Toroidal 2x anamorphic 50 mm (written for lensim)')
w('NOTE 0 A toroidal front attachment, afocal in both sections (x: Galilean wide-angle 0.49x, saddle-shaped')
w('NOTE 0 toroids; y: weak menisci), in front of the 50 mm f/2 double Gauss of lenses/dgauss.50mm.dat')
Mx=trace(surfs,'x'); My=trace(surfs,'y')
w(f'NOTE 0 (US 2,673,491, Tronnier) with the nearest Schott glasses. EFL_y {-1/My[1][0]:.2f} mm, EFL_x {-1/Mx[1][0]:.2f} mm, squeeze {Mx[1][0]/My[1][0]:.2f}.')
w('UNIT MM X W X CM MR CPMM')
w('FLOA')
w('WAVM 1 0.4861327 1')
w('WAVM 2 0.5875618 1')
w('WAVM 3 0.6562725 1')
w('PWAV 2')
w('FTYP 0 0 1 3 0 0 0')
w('SURF 0\n  TYPE STANDARD\n  CURV 0.0 0 0 0 0 ""\n  DISZ INFINITY\n  DIAM 0 0 0 0 1 ""')
n=1
def surf(typ, curv, disz, diam, glass=None, parms=None, stop=False):
    global n
    w(f'SURF {n}')
    if stop: w('  STOP')
    w(f'  TYPE {typ}')
    w(f'  CURV {curv:.15g} 0 0 0 0 ""')
    if parms:
        for i,v in parms: w(f'  PARM {i} {v:.15g}')
    w(f'  DISZ {disz:.15g}')
    if glass: w(f'  GLAS {glass[0]} 0 0 {glass[1]:.6f} {glass[2]:.2f} 0 0 0 0 0 0')
    w(f'  DIAM {diam:.6g} 0 0 0 1 ""')
    n+=1
gA=('F2',1.620040,36.37)
gB=('N-FK5',1.487490,70.41)
surf('TOROIDAL',1/Ry,2.5,24,gA,[(1,Rx1),(2,0)])
surf('TOROIDAL',1/Ry,sep,24,None,[(1,Rx2)])
surf('TOROIDAL',1/Ry,6.0,19,gB,[(1,Rx3)])
surf('TOROIDAL',1/Ry4,gap,19,None,[(1,Rx4)])
for k,(r,t,nn) in enumerate(prime):
    g=glass_prime.get(nn)
    disz=t if k<len(prime)-1 else 36.054288
    surf('STANDARD',1/r if r else 0.0,disz,pdiam[k]/2,g,None,stop=(r==0))
w(f'SURF {n}\n  TYPE STANDARD\n  CURV 0.0 0 0 0 0 ""\n  DISZ 0\n  DIAM 21.6 0 0 0 1 ""')
open(os.path.join(os.path.dirname(os.path.abspath(__file__)), 'toroidal-anamorphic.50mm.zmx'),'w').write('\n'.join(out)+'\n')
