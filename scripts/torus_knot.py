#!/usr/bin/env python3
# Writes assets/meshes/knot.obj (or argv[1]): a (2,3) torus knot's tube, a closed mesh
# (torus topology, outward winding) whose strands shadow each other: the
# self-shadowing test of docs/meshes.md. Curve ((2 + cos 3t) cos 2t, (2 + cos 3t) sin 2t,
# sin 3t), tube radius 0.4, 240 rings of 16 vertices.
import math, sys
p,q=2,3; N=240; M=16; R=0.4
def c(t): 
    r=2+math.cos(q*t); return (r*math.cos(p*t), r*math.sin(p*t), math.sin(q*t))
def sub(a,b): return tuple(x-y for x,y in zip(a,b))
def cross(a,b): return (a[1]*b[2]-a[2]*b[1],a[2]*b[0]-a[0]*b[2],a[0]*b[1]-a[1]*b[0])
def norm(a): l=math.sqrt(sum(x*x for x in a)); return tuple(x/l for x in a)
V=[];F=[]
for i in range(N):
    t=2*math.pi*i/N; P=c(t); T=norm(sub(c(t+1e-4),c(t-1e-4)))
    A=norm(cross(T,(0,0,1))); B=cross(T,A)
    for j in range(M):
        a=2*math.pi*j/M
        V.append(tuple(P[k]+R*(math.cos(a)*A[k]+math.sin(a)*B[k]) for k in range(3)))
for i in range(N):
    for j in range(M):
        a=i*M+j; b=((i+1)%N)*M+j; cc=((i+1)%N)*M+(j+1)%M; d=i*M+(j+1)%M
        F.append((a,b,cc)); F.append((a,cc,d))
# orientation check: signed volume
vol=sum( (V[a][0]*(V[b][1]*V[cc][2]-V[b][2]*V[cc][1]) - V[a][1]*(V[b][0]*V[cc][2]-V[b][2]*V[cc][0]) + V[a][2]*(V[b][0]*V[cc][1]-V[b][1]*V[cc][0]))/6 for a,b,cc in F)
if vol<0: F=[(a,cc,b) for a,b,cc in F]
with open(sys.argv[1] if len(sys.argv) > 1 else 'assets/meshes/knot.obj','w') as f:
    for v in V: f.write('v %.9f %.9f %.9f\n'%v)
    for t in F: f.write('f %d %d %d\n'%(t[0]+1,t[1]+1,t[2]+1))
print(len(V),len(F),abs(vol))
