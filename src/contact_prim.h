/* SPDX-License-Identifier: MIT */
/*
 * Distances between surface primitives for body-body and self-contact (contact_prim.c): point-
 * triangle, edge-edge and point-edge squared distances with exact gradients and Hessians, the
 * edge-edge mollifier of IPC for nearly parallel edges, and additive continuous collision
 * detection (ACCD, Li, Kaufman and Jiang 2021).
 *
 * Squared distances are used throughout (smooth where the distance itself is not). Each pair's
 * distance is that of its closest features, chosen by region: the derivatives are those of the
 * formula for that region (point-point, point-line, point-plane or line-line), which agree in
 * value and gradient across region boundaries. Coordinates come as separate 3-vectors; the
 * gradient (12 or 9 doubles) and Hessian (row-major, 144 or 81) are over the vertices in the order
 * of the arguments. g and H may be NULL.
 */
#ifndef DEFSIM_CONTACT_PRIM_H
#define DEFSIM_CONTACT_PRIM_H

/* Which formula a pair's distance came from (the closest features). */
typedef enum defsim__dtype {
    DEFSIM__D_PP = 0,   /* point-point */
    DEFSIM__D_PE = 1,   /* point-line (a point and the interior of an edge) */
    DEFSIM__D_PT = 2,   /* point-plane (a point and the interior of a triangle) */
    DEFSIM__D_EE = 3    /* line-line (the interiors of two edges) */
} defsim__dtype;

/* Point p against triangle (t0, t1, t2). */
double defsim__pt_dist2(const double p[3], const double t0[3], const double t1[3],
                        const double t2[3], double g[12], double H[144], defsim__dtype *type);

/* Segment (a0, a1) against segment (b0, b1). Nearly parallel edges (|ea x eb|^2 below 1e-20 of
 * |ea|^2 |eb|^2) take their distance from the endpoint-to-segment candidates, which is exact for
 * parallel segments; the mollifier below makes the barrier smooth across that switch. */
double defsim__ee_dist2(const double a0[3], const double a1[3], const double b0[3],
                        const double b1[3], double g[12], double H[144], defsim__dtype *type);

/* Point p against segment (e0, e1): ropes. */
double defsim__pe_dist2(const double p[3], const double e0[3], const double e1[3], double g[9],
                        double H[81], defsim__dtype *type);

/* The closest features of a pair, for kernels that specialise by region: the formula that
 * the functions above use (*type), its squared distance (*d2) and the pair's vertices that it
 * involves, as indices into the pair's vertices in the formula's order (PP: the two points; PE:
 * the point, then the edge's ends; PT: p, t0, t1, t2; EE: a0, a1, b0, b1). Returns how many
 * (2, 3 or 4). x packs the vertices as the functions above take them. */
int defsim__pt_closest(const double x[12], double *d2, defsim__dtype *type, int nodes[4]);
int defsim__ee_closest(const double x[12], double *d2, defsim__dtype *type, int nodes[4]);
int defsim__pe_closest(const double x[9], double *d2, defsim__dtype *type, int nodes[4]);

/* The closest point of triangle (a, b, c) to p by the Voronoi regions of its features
 * (Ericson, Real-Time Collision Detection, 5.1.5): returns the feature, 0, 1, 2 the corner a, b,
 * c; 3 + k the edge from corner k to corner k + 1 (ab, bc, ca); 6 the face. w receives the
 * barycentric weights of a, b, c of the closest point: the region's parameter itself on an edge
 * (w[1] from a along ab, w[2] from a along ac, w[2] from b along bc), vb / (va + vb + vc) and
 * vc / (va + vb + vc) in w[1] and w[2] on the face; the other weight is 1 minus them. */
int defsim__triangle_closest(const double p[3], const double a[3], const double b[3],
                             const double c[3], double w[3]);

/* IPC's edge-edge mollifier m(c), c = |(a1 - a0) x (b1 - b0)|^2: m = (2 - c / eps) c / eps below
 * eps and 1 above; multiplies the edge-edge barrier so that it vanishes smoothly as the edges
 * become parallel, where the closest-feature switch would make the barrier non-smooth.
 * defsim__ee_mollifier_eps gives eps = 1e-3 |a1 - a0|^2 |b1 - b0|^2 from rest positions. */
double defsim__ee_mollifier(const double a0[3], const double a1[3], const double b0[3],
                            const double b1[3], double eps, double g[12], double H[144]);
double defsim__ee_mollifier_eps(const double a0[3], const double a1[3], const double b0[3],
                                const double b1[3]);

/* Additive CCD: the four vertices x (12 doubles: p, t0, t1, t2 for a point-triangle pair, or
 * a0, a1, b0, b1 for an edge-edge pair) move linearly by dx over t in [0, 1]. Returns a time
 * t in [0, tmax] such that the pair's distance stays above zero over [0, t]: either t < tmax and
 * the distance at t is at least s (0 <= s < 1) times the starting distance, or t = tmax (the last
 * conservative advance reached tmax). Conservative by construction: each advance is 0.9 of the
 * distance divided by a bound on the relative speed (the largest difference between a
 * displacement of the one primitive and one of the other), so the distance stays above a tenth
 * of its value at the advance's start. When an advance ends below s times the starting
 * distance, the crossing inside it is bisected (12 halvings) and the last time found at or above
 * that gap is returned, not the advance's start as in ACCD (Li, Kaufman and Jiang 2021). With
 * s = 0.1 the rule is IPC Toolkit's additive CCD with conservative_rescaling 0.9 (its gap is
 * (1 - 0.9) of the starting distance), and the result at least as large in practice (see
 * tools/bench_contact_kernel.c). Stops after max_iterations advances and returns the time
 * reached (still conservative). 0 if the pair starts at distance 0. */
double defsim__pt_accd(const double x[12], const double dx[12], double s, double tmax,
                       int max_iterations);
double defsim__ee_accd(const double x[12], const double dx[12], double s, double tmax,
                       int max_iterations);
/* The same for a point p and a segment (e0, e1): x and dx hold p, e0, e1 (9 doubles). */
double defsim__pe_accd(const double x[9], const double dx[9], double s, double tmax,
                       int max_iterations);

/* The loop behind the three functions above, for callers that know the pair's start distance
 * d0 (> 0) and its relative speed lp (defsim__ccd_speed): pair is the kind, x and dx hold four
 * vertices (point-edge: p, e0, e1 and e1 again). Same result as the function of its kind. */
typedef enum defsim__ccd_pair {
    DEFSIM__CCD_PT = 0,   /* p, t0, t1, t2 */
    DEFSIM__CCD_EE = 1,   /* a0, a1, b0, b1 */
    DEFSIM__CCD_PE = 2    /* p, e0, e1, e1 */
} defsim__ccd_pair;
double defsim__accd(defsim__ccd_pair pair, const double x[12], const double dx[12], double d0,
                    double lp, double s, double tmax, int max_iterations);
/* The same with a minimum separation xi >= 0 (m, the contact thickness): the advancement works
 * on the distance less xi (Lipschitz with the same lp), d0 is that offset distance at t = 0
 * (> 0), and the result keeps the distance at least xi + s d0 for every point up to it; xi = 0
 * is defsim__accd, bit for bit. */
double defsim__accd_offset(defsim__ccd_pair pair, const double x[12], const double dx[12],
                           double d0, double xi, double lp, double s, double tmax,
                           int max_iterations);
/* A bound on how fast the pair's distance changes along dx (per unit t): the largest difference
 * between a displacement of the first primitive's vertices and one of the second's. */
double defsim__ccd_speed(defsim__ccd_pair pair, const double dx[12]);

#endif /* DEFSIM_CONTACT_PRIM_H */
