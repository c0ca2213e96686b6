/* SPDX-License-Identifier: MIT */
/*
 * Exact geometric predicates for tests that check contact independently of the solver: the sign
 * of orient3d evaluated in exact floating-point expansion arithmetic (Shewchuk's technique: sums
 * and products carried as non-overlapping expansions, no rounding anywhere), and on top of it an
 * exact triangle-triangle intersection test and an exact point-in-tetrahedron test. Slow (a few
 * microseconds per predicate) and meant for tests only.
 */
#ifndef DEFSIM_EXACT_GEOM_H
#define DEFSIM_EXACT_GEOM_H

/* Sign (-1, 0, 1) of det[a - d; b - d; c - d]: positive when d lies below the plane of a, b, c
 * seen counterclockwise from above (the sign of (b - a) x (c - a) . (a - d)). Exact. */
int eg_orient3d(const double a[3], const double b[3], const double c[3], const double d[3]);

/* Sign of the 2D orientation of (a, b, c) in the plane of coordinates (i, j). Exact. */
int eg_orient2d(const double a[3], const double b[3], const double c[3], int i, int j);

/* 1 if the closed triangles (p0, p1, p2) and (q0, q1, q2) share a point. Exact, coplanar and
 * degenerate cases included. Callers exclude triangles that share a vertex. */
int eg_tri_tri_intersect(const double p0[3], const double p1[3], const double p2[3],
                         const double q0[3], const double q1[3], const double q2[3]);

/* 1 if x lies strictly inside the tetrahedron (a, b, c, d) (either orientation). Exact. */
int eg_point_in_tet(const double x[3], const double a[3], const double b[3], const double c[3],
                    const double d[3]);

/* Distances in plain floating point (closest points by region, not exact: rounding of the order
 * of 1e-16 of the coordinates), for tests that check a minimum separation (the contact
 * thickness) independently of the library's distance code.
 * eg_tri_tri_gap: the distance between two triangles that do not intersect, the least of the
 * six vertex-triangle distances (the plane's distance where the point projects inside, else the
 * nearest edge) and the nine edge-edge distances (the interior critical point where it lies in
 * both segments, else an end against the other segment). eg_tri_tri_distance: 0 when
 * eg_tri_tri_intersect says they meet, else the gap. eg_point_tri_distance: x to the triangle. */
double eg_tri_tri_gap(const double p0[3], const double p1[3], const double p2[3],
                      const double q0[3], const double q1[3], const double q2[3]);
double eg_tri_tri_distance(const double p0[3], const double p1[3], const double p2[3],
                           const double q0[3], const double q1[3], const double q2[3]);
double eg_point_tri_distance(const double x[3], const double a[3], const double b[3],
                             const double c[3]);

#endif /* DEFSIM_EXACT_GEOM_H */
