# SPDX-License-Identifier: MIT
"""Independent 2D check of the reference of Cook's membrane in tests/unit/test_tet10_accuracy.c.

Plane-stress (and plane-strain) linear elasticity on the tapered panel (0,0), (48,44), (48,60),
(0,44), clamped at x = 0, a uniform vertical shear of total force 1 on the edge x = 48, E = 1,
nu = 1/3, thickness 1, by 6-node triangles (P2, the 3-point degree-2 rule: exact for their
stiffness on straight triangles) on n x n quads of the bilinear map of the unit square, each cut
into 2, solved densely with numpy. Prints the vertical displacement at the middle of the loaded
edge (48, 52), the literature's point, and at the top right corner (48, 60), per mesh:

    n   plane stress (48, 52)  (48, 60)   plane strain (48, 52)  (48, 60)
    4                  23.482    24.318                 20.897    21.663
    8                  23.857    24.815                 21.356    22.201
    16                 23.926    25.024                 21.458    22.430
    24                 23.944    25.084                 21.484    22.496

At (48, 52) plane stress converges to the literature's 23.96 (Cook, Malkus and Plesha 1989); the
corner converges to about 25.17. The 3D thin plate of the C test converges to 23.946 at (48, 52).
Run: python3 tests/tools/cook_plane_stress.py (a minute; 24 per side holds a 4802^2 dense matrix).
"""
import numpy as np, sys
def solve(n, plane='stress', E=1.0, nu=1/3.):
    # nodes on a (2n+1)^2 grid in (u,v), mapped
    N = 2*n+1
    idx = lambda i,j: i + N*j
    P = np.zeros((N*N,2))
    for j in range(N):
        for i in range(N):
            u, v = i/(N-1), j/(N-1)
            P[idx(i,j)] = [48*u, 44*u + v*(44-28*u)]
    tris = []
    for j in range(n):
        for i in range(n):
            a,b,c,d = (2*i,2*j),(2*i+2,2*j),(2*i+2,2*j+2),(2*i,2*j+2)
            for (p,q,r) in [(a,b,c),(a,c,d)]:
                m = lambda s,t: ((s[0]+t[0])//2,(s[1]+t[1])//2)
                tris.append([idx(*p),idx(*q),idx(*r),idx(*m(p,q)),idx(*m(q,r)),idx(*m(r,p))])
    if plane=='stress':
        D = E/(1-nu**2)*np.array([[1,nu,0],[nu,1,0],[0,0,(1-nu)/2]])
    else:
        D = E/((1+nu)*(1-2*nu))*np.array([[1-nu,nu,0],[nu,1-nu,0],[0,0,(1-2*nu)/2]])
    ndof = 2*N*N
    K = np.zeros((ndof,ndof))
    qp = [(1/6,1/6),(2/3,1/6),(1/6,2/3)]; qw = 1/6
    for t in tris:
        X = P[t]
        Ke = np.zeros((12,12))
        for (r,s) in qp:
            L = [1-r-s, r, s]
            dL = np.array([[-1,-1],[1,0],[0,1]],float)
            dN = np.zeros((6,2))
            for a in range(3): dN[a] = (4*L[a]-1)*dL[a]
            for k,(a,b) in enumerate([(0,1),(1,2),(2,0)]):
                dN[3+k] = 4*(L[a]*dL[b] + L[b]*dL[a])
            J = X.T @ dN   # 2x2
            G = dN @ np.linalg.inv(J)
            B = np.zeros((3,12))
            B[0,0::2] = G[:,0]; B[1,1::2] = G[:,1]; B[2,0::2] = G[:,1]; B[2,1::2] = G[:,0]
            Ke += qw*abs(np.linalg.det(J))*B.T@D@B
        dofs = np.array([[2*v,2*v+1] for v in t]).ravel()
        K[np.ix_(dofs,dofs)] += Ke
    f = np.zeros(ndof)
    # right edge i = N-1: segments of 3 nodes (P2 line): loads 1/6, 4/6, 1/6 of segment length share
    for j in range(0, N-1, 2):
        a,m,b = idx(N-1,j), idx(N-1,j+1), idx(N-1,j+2)
        Lseg = np.linalg.norm(P[b]-P[a]); q = 1/16
        f[2*a+1] += q*Lseg/6; f[2*m+1] += q*Lseg*4/6; f[2*b+1] += q*Lseg/6
    fixed = [d for j in range(N) for d in (2*idx(0,j), 2*idx(0,j)+1)]
    free = np.setdiff1d(np.arange(ndof), fixed)
    u = np.zeros(ndof)
    u[free] = np.linalg.solve(K[np.ix_(free,free)], f[free])
    return u[2*idx(N-1,(N-1)//2)+1], u[2*idx(N-1,N-1)+1]
print('n   plane stress (48, 52)  (48, 60)   plane strain (48, 52)  (48, 60)')
for n in [4,8,16,24]:
    a, b = solve(n,'stress'); c, d = solve(n,'strain')
    print('%-3d %22.3f %9.3f %22.3f %9.3f' % (n, a, b, c, d))
    sys.stdout.flush()
