// SPDX-License-Identifier: MIT
// Tests of the C++ wrapper (defsim.hpp): ownership and moves, exceptions with status codes,
// size checks, and that it computes exactly what the C API computes.
#include <defsim/defsim.hpp>

#include "mesh_body.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

static int failures = 0;

// Not assert(): the tests build in Release, where NDEBUG removes assert.
#define CHECK(cond)                                                                     \
    do {                                                                                \
        if (!(cond)) {                                                                  \
            std::fprintf(stderr, "%s:%d: CHECK failed: %s\n", __FILE__, __LINE__, #cond); \
            ++failures;                                                                 \
        }                                                                               \
    } while (0)

// Runs `body`, which must throw defsim::Error with status `code`.
template <class F>
static bool throws_status(defsim_status code, F &&body)
{
    try {
        body();
    } catch (const defsim::Error &e) {
        return e.status() == code && std::strlen(e.what()) > 0;
    }
    return false;
}

static void test_version()
{
    CHECK(defsim::library_compatible());
    CHECK(defsim::library_version() == DEFSIM_VERSION_NUMBER);
}

static void test_mesh()
{
    defsim::Mesh m = defsim::Mesh::box({0, 0, 0}, {1, 1, 1}, 2, 1, 1);
    CHECK(m.vertex_count() == 12);
    CHECK(m.tet_count() == 12);
    CHECK(m.positions().size() == 36);
    CHECK(m.tets().size() == 48);
    // Boundary: 2 triangles per boundary cell face: 2 * (1 + 2 + 2) faces per side pair.
    CHECK(m.triangle_count() == 20);
    CHECK(m.spring_count() == 0 && m.springs().empty());
    // Vertex i + 3 (j + 2 k) sits at (i / 2, j, k).
    for (int k = 0; k <= 1; ++k)
        for (int j = 0; j <= 1; ++j)
            for (int i = 0; i <= 2; ++i) {
                const std::size_t v = static_cast<std::size_t>(i + 3 * (j + 2 * k));
                CHECK(m.positions()[3 * v] == 0.5 * i);
                CHECK(m.positions()[3 * v + 1] == j);
                CHECK(m.positions()[3 * v + 2] == k);
            }
    defsim::Mesh moved = std::move(m);
    CHECK(moved.vertex_count() == 12);
    CHECK(m.vertex_count() == 0 && m.positions().data() == nullptr);   // NOLINT(bugprone-use-after-move)
    m = std::move(moved);
    CHECK(m.vertex_count() == 12 && moved.vertex_count() == 0);
    // Quadratic tets: a vertex at every edge's middle, 10 indices per tet, and a body of them
    // whose lumped masses add up to rho V.
    defsim::Mesh q = defsim::Mesh::box({0, 0, 0}, {1, 1, 1}, 2, 1, 1);
    q.make_quadratic();
    CHECK(q.tet_nodes() == 10 && q.tet_count() == 12 && q.tets().size() == 120);
    CHECK(q.vertex_count() == 5 * 3 * 3);
    CHECK(throws_status(DEFSIM_ERR_INVALID_ARGUMENT, [&q] { q.make_quadratic(); }));
    {
        defsim::World w(defsim::WorldDef().backend("symplectic_euler"));
        w.add_body(defsim::BodyDef(q).material(defsim::Material(defsim::Model::corotated)
                                                   .density(1000.0)));
        std::vector<double> mass(static_cast<std::size_t>(w.vertex_count()));
        w.get_masses(mass);
        double total = 0.0;
        for (double x : mass) total += x;
        CHECK(std::fabs(total - 1000.0) < 1e-9);
    }
    CHECK(throws_status(DEFSIM_ERR_INVALID_ARGUMENT, [] { defsim::Mesh::box({0, 0, 0}, {1, 1, 1}, 0, 1, 1); }));
    CHECK(throws_status(DEFSIM_ERR_INVALID_ARGUMENT, [] { defsim::Mesh::box({0, 0, 0}, {0, 1, 1}, 1, 1, 1); }));

    defsim_mesh raw = {sizeof raw, nullptr, 0, nullptr, 0, nullptr, 0, nullptr, 0, nullptr, 0};
    const double lo[3] = {0, 0, 0}, hi[3] = {1, 2, 3};
    CHECK(defsim_mesh_box(lo, hi, 1, 1, 1, &raw) == DEFSIM_OK);
    defsim::Mesh adopted = defsim::Mesh::adopt(raw);
    CHECK(adopted.vertex_count() == 8 && raw.positions == nullptr && raw.vertex_count == 0);
    CHECK(adopted.positions()[3 * 7 + 2] == 3.0);
}

// One free vertex of 1 kg under gravity: after n steps symplectic Euler gives
// v = n h g, y = h^2 g n (n + 1) / 2; explicit Euler gives y = h^2 g n (n - 1) / 2.
static void test_free_fall()
{
    const double g = -9.81, h = 1e-3;
    const int n = 200;
    for (int symplectic = 0; symplectic <= 1; ++symplectic) {
        defsim::World w(defsim::WorldDef()
                            .backend(symplectic ? "symplectic_euler" : "explicit_euler")
                            .gravity(0, g, 0));
        const double p[3] = {0, 0, 0};
        w.add_body(defsim::BodyDef()
                       .rest_positions(p)
                       .material(defsim::Material(defsim::Model::spring).vertex_mass(1.0)));
        for (int i = 0; i < n; ++i) w.step(h);
        const std::vector<double> x = w.positions(), v = w.velocities();
        const double y = h * h * g * n * (symplectic ? n + 1 : n - 1) / 2.0;
        CHECK(std::fabs(v[1] - n * h * g) < 1e-12);
        CHECK(std::fabs(x[1] - y) < 1e-12);
        CHECK(x[0] == 0.0 && x[2] == 0.0);
        CHECK(std::fabs(w.time() - n * h) < 1e-12);
        CHECK(w.stats().steps == n);
    }
}

// The same clamped beam through the raw C API and through the wrapper: bit-identical.
static std::vector<double> beam_c(int steps)
{
    defsim_world_def wd;
    defsim_world_def_init(&wd, sizeof wd);
    wd.num_threads = 2;
    defsim_world *w = nullptr;
    if (defsim_world_create(&wd, &w) != DEFSIM_OK) return {};
    defsim_mesh m = {sizeof m, nullptr, 0, nullptr, 0, nullptr, 0, nullptr, 0, nullptr, 0};
    const double lo[3] = {0, 0, 0}, hi[3] = {0.8, 0.2, 0.2};
    defsim_mesh_box(lo, hi, 4, 1, 1, &m);
    defsim_body_def bd = test_mesh_body(&m, DEFSIM_MODEL_STABLE_NEOHOOKEAN);
    bd.material.youngs_modulus = 3e5;
    bd.material.mass_damping = 0.3;
    defsim_body_id id;
    defsim_world_add_body(w, &bd, &id);
    std::vector<int32_t> pins;
    for (int32_t i = 0; i < m.vertex_count; ++i)
        if (m.positions[3 * i] == 0.0) pins.push_back(i);
    defsim_body_pin(w, id, pins.data(), static_cast<int32_t>(pins.size()));
    for (int s = 0; s < steps; ++s) defsim_world_step(w, 5e-4);
    std::vector<double> x(3 * static_cast<std::size_t>(m.vertex_count));
    defsim_world_get_positions(w, x.data(), m.vertex_count);
    defsim_mesh_free(&m);
    defsim_world_destroy(w);
    return x;
}

static std::vector<double> beam_cpp(int steps)
{
    defsim::World w(defsim::WorldDef().num_threads(2));
    const defsim::Mesh m = defsim::Mesh::box({0, 0, 0}, {0.8, 0.2, 0.2}, 4, 1, 1);
    const defsim::Body b = w.add_body(defsim::BodyDef(m).material(
        defsim::Material(defsim::Model::stable_neohookean).youngs_modulus(3e5).mass_damping(0.3)));
    std::vector<int32_t> pins;
    for (int32_t i = 0; i < m.vertex_count(); ++i)
        if (m.positions()[3 * static_cast<std::size_t>(i)] == 0.0) pins.push_back(i);
    w.pin(b, pins);
    for (int s = 0; s < steps; ++s) w.step(5e-4);
    return w.positions();
}

static void test_matches_c()
{
    const std::vector<double> a = beam_c(100), b = beam_cpp(100);
    CHECK(!a.empty() && a.size() == b.size());
    CHECK(std::memcmp(a.data(), b.data(), a.size() * sizeof(double)) == 0);
    double lowest = 0.0;
    for (std::size_t i = 1; i < b.size(); i += 3) lowest = std::min(lowest, b[i]);
    CHECK(lowest < -1e-4);   // the beam did move
}

static void test_errors()
{
    CHECK(throws_status(DEFSIM_ERR_BACKEND_UNAVAILABLE,
                        [] { defsim::World w(defsim::WorldDef().backend("no_such_backend")); }));
    CHECK(throws_status(DEFSIM_ERR_INVALID_ARGUMENT,
                        [] { defsim::World w(defsim::WorldDef().num_threads(-1)); }));

    defsim::World w;
    const defsim::Mesh m = defsim::Mesh::box({0, 0, 0}, {1, 1, 1}, 1, 1, 1);
    // Sizes the C API could not check are checked before the call.
    CHECK(throws_status(DEFSIM_ERR_INVALID_ARGUMENT, [&] {
        const std::vector<double> masses(3, 1.0);   // the box has 8 vertices
        w.add_body(defsim::BodyDef(m).vertex_mass(masses));
    }));
    CHECK(throws_status(DEFSIM_ERR_INVALID_ARGUMENT, [&] {
        const double p[4] = {0, 0, 0, 1};
        defsim::BodyDef().rest_positions(p);
    }));
    CHECK(w.vertex_count() == 0);
    // The library's own checks arrive as the matching status.
    CHECK(throws_status(DEFSIM_ERR_INVALID_MATERIAL, [&] {
        w.add_body(defsim::BodyDef(m).material(defsim::Material().poisson_ratio(0.5)));
    }));
    CHECK(throws_status(DEFSIM_ERR_INVALID_MESH, [&] {
        const int32_t bad[4] = {0, 1, 2, 8};
        w.add_body(defsim::BodyDef().rest_positions(m.positions()).tets(bad));
    }));
    CHECK(throws_status(DEFSIM_ERR_INVALID_MATERIAL, [&] {
        w.add_body(defsim::BodyDef(m).material(defsim::Material(defsim::Model::spring)));
    }));
    CHECK(w.vertex_count() == 0);

    const defsim::Body b = w.add_body(defsim::BodyDef(m));
    CHECK(!b.is_null() && w.vertex_count() == 8 && w.vertex_count(b) == 8);
    std::vector<double> out(5);
    CHECK(throws_status(DEFSIM_ERR_INVALID_ARGUMENT, [&] { w.get_positions(out); }));
    CHECK(throws_status(DEFSIM_ERR_INVALID_ARGUMENT, [&] { w.set_positions(out); }));
    const int32_t far[1] = {8};
    CHECK(throws_status(DEFSIM_ERR_INVALID_ARGUMENT, [&] { w.pin(b, far); }));

    // A failed step changes nothing: not h, and not an unstable explicit step either.
    const std::vector<double> x0 = w.positions();
    CHECK(throws_status(DEFSIM_ERR_INVALID_ARGUMENT, [&] { w.step(-1.0); }));
    CHECK(w.try_step(std::nan("")) == DEFSIM_ERR_INVALID_ARGUMENT);
    CHECK(!w.last_error().empty());
    CHECK(w.positions() == x0 && w.time() == 0.0);

    defsim::World ex(defsim::WorldDef().backend("explicit_euler"));
    const defsim::Body stiff = ex.add_body(defsim::BodyDef(m).material(
        defsim::Material(defsim::Model::corotated).youngs_modulus(1e9)));
    std::vector<double> kick = ex.positions();
    kick[0] -= 0.3;   // a large deformation, then a step far beyond stability
    ex.set_positions(kick);
    defsim_status st = DEFSIM_OK;
    int tries = 0;
    while (st == DEFSIM_OK && tries++ < 500) {
        kick = ex.positions();
        st = ex.try_step(10.0);
    }
    CHECK(st == DEFSIM_ERR_UNSTABLE);
    CHECK(ex.positions() == kick);
    CHECK(ex.stats().failed_steps == 1);

    // Stale ids.
    ex.remove_body(stiff);
    CHECK(ex.vertex_count() == 0);
    CHECK(throws_status(DEFSIM_ERR_STALE_ID, [&] { ex.remove_body(stiff); }));
    CHECK(throws_status(DEFSIM_ERR_STALE_ID, [&] { ex.vertex_count(stiff); }));
    const int32_t v0[1] = {0};
    CHECK(throws_status(DEFSIM_ERR_STALE_ID, [&] { ex.pin(stiff, v0); }));
    CHECK(throws_status(DEFSIM_ERR_STALE_ID, [&] { ex.pin(defsim::Body(), v0); }));
}

static void test_moves_and_log()
{
    int errors_logged = 0;
    defsim::World a(defsim::WorldDef().log([&](int level, const char *) {
        if (level == 0) ++errors_logged;
    }));
    const defsim::Mesh m = defsim::Mesh::box({0, 0, 0}, {1, 1, 1}, 1, 1, 1);
    a.add_body(defsim::BodyDef(m));
    defsim_world *raw = a.get();
    defsim::World b = std::move(a);
    CHECK(!a && a.get() == nullptr && a.vertex_count() == 0);   // NOLINT(bugprone-use-after-move)
    CHECK(b && b.get() == raw && b.vertex_count() == 8);
    CHECK(throws_status(DEFSIM_ERR_INVALID_ARGUMENT, [&] { a.step(1e-3); }));
    CHECK(throws_status(DEFSIM_ERR_INVALID_ARGUMENT, [&] { a.positions(); }));
    // The log sink moved with the world and still works.
    CHECK(b.try_step(-1.0) == DEFSIM_ERR_INVALID_ARGUMENT);
    CHECK(errors_logged == 1);
    defsim::World c;
    c = std::move(b);
    CHECK(c.try_step(0.0) == DEFSIM_ERR_INVALID_ARGUMENT);
    CHECK(errors_logged == 2);
    defsim_world *released = c.release();
    CHECK(!c && released == raw);
    // Released: the wrapper's sink is detached and freed (it used to be leaked), so the world
    // logs nowhere; a sink set with the C API is called.
    CHECK(defsim_world_step(released, -1.0) == DEFSIM_ERR_INVALID_ARGUMENT);
    CHECK(errors_logged == 2);
    int c_logged = 0;
    CHECK(defsim_world_set_log(released, [](void *user, int, const char *) {
        ++*static_cast<int *>(user);
    }, &c_logged) == DEFSIM_OK);
    CHECK(defsim_world_step(released, -1.0) == DEFSIM_ERR_INVALID_ARGUMENT);
    CHECK(c_logged == 1 && errors_logged == 2);
    CHECK(defsim_world_set_log(nullptr, nullptr, nullptr) == DEFSIM_ERR_INVALID_ARGUMENT);
    defsim_world_destroy(released);
}

// StVK at F = diag(s, 1, 1): E11 = (s^2 - 1) / 2, psi = (mu + lambda / 2) E11^2,
// P11 = s (2 mu + lambda) E11, P22 = P33 = lambda E11.
static void test_material_eval()
{
    const double E = 2e5, nu = 0.25, s = 1.1;
    const double mu = E / (2 * (1 + nu)), lambda = E * nu / ((1 + nu) * (1 - 2 * nu));
    const double e11 = (s * s - 1) / 2;
    const auto r = defsim::material_eval(
        defsim::Material(defsim::Model::stvk).youngs_modulus(E).poisson_ratio(nu),
        {s, 0, 0, 0, 1, 0, 0, 0, 1});
    CHECK(std::fabs(r.psi - (mu + lambda / 2) * e11 * e11) < 1e-9 * r.psi);
    CHECK(std::fabs(r.P[0] - s * (2 * mu + lambda) * e11) < 1e-9 * r.P[0]);
    CHECK(std::fabs(r.P[4] - lambda * e11) < 1e-9 * r.P[4]);
    CHECK(r.P[1] == 0.0 && r.P[8] == r.P[4]);
    CHECK(throws_status(DEFSIM_ERR_UNSTABLE, [] {
        defsim::material_eval(defsim::Material(defsim::Model::neohookean), {-1, 0, 0, 0, 1, 0, 0, 0, 1});
    }));
    CHECK(throws_status(DEFSIM_ERR_INVALID_ARGUMENT, [] {
        defsim::material_eval(defsim::Material(defsim::Model::spring), {1, 0, 0, 0, 1, 0, 0, 0, 1});
    }));
}

// Energies against sums over masses, positions and velocities; forces against central
// differences of the elastic energy.
static void test_energy_forces()
{
    defsim::World w(defsim::WorldDef().gravity(0.3, -9.81, 0.1));
    const defsim::Mesh m = defsim::Mesh::box({0, 0, 0}, {0.3, 0.2, 0.1}, 2, 1, 1);
    w.add_body(defsim::BodyDef(m).material(
        defsim::Material(defsim::Model::corotated).youngs_modulus(1e5).density(800)));
    const std::size_t n = static_cast<std::size_t>(w.vertex_count());
    std::vector<double> x = w.positions(), v(3 * n);
    for (std::size_t i = 0; i < 3 * n; ++i) {
        x[i] += 0.02 * std::sin(1.7 * static_cast<double>(i) + 0.3);
        v[i] = 0.5 * std::cos(0.9 * static_cast<double>(i));
    }
    w.set_state(x, v);
    const std::vector<double> mass = w.masses();
    double ke = 0, ge = 0, total_mass = 0;
    const double g[3] = {0.3, -9.81, 0.1};
    for (std::size_t i = 0; i < n; ++i) {
        total_mass += mass[i];
        for (int c = 0; c < 3; ++c) {
            ke += 0.5 * mass[i] * v[3 * i + c] * v[3 * i + c];
            ge -= mass[i] * g[c] * x[3 * i + c];
        }
    }
    CHECK(std::fabs(total_mass - 800 * 0.3 * 0.2 * 0.1) < 1e-12);
    const defsim_energy e = w.energy();
    CHECK(std::fabs(e.kinetic - ke) <= 1e-12 * ke);
    CHECK(std::fabs(e.gravitational - ge) <= 1e-12 * std::fabs(ge));
    CHECK(e.elastic > 0 && std::fabs(e.total - (e.kinetic + e.elastic + e.gravitational)) < 1e-12);

    const std::vector<double> f = w.forces();
    std::vector<double> f_at(3 * n);
    w.forces(x, f_at);
    CHECK(f == f_at);
    double worst = 0, fmax = 0;
    const double d = 1e-6;
    for (std::size_t i = 0; i < 3 * n; ++i) {
        std::vector<double> xp = x, xm = x;
        xp[i] += d;
        xm[i] -= d;
        w.set_positions(xp);
        const double ep = w.energy().elastic;
        w.set_positions(xm);
        const double em = w.energy().elastic;
        worst = std::max(worst, std::fabs(-(ep - em) / (2 * d) - f[i]));
        fmax = std::max(fmax, std::fabs(f[i]));
    }
    CHECK(fmax > 1.0);
    CHECK(worst < 1e-6 * fmax);
}

static void test_bodies()
{
    defsim::World w;
    const defsim::Mesh m1 = defsim::Mesh::box({0, 0, 0}, {1, 1, 1}, 1, 1, 1);
    const defsim::Mesh m2 = defsim::Mesh::box({2, 0, 0}, {3, 1, 1}, 2, 1, 1);
    const defsim::Body a = w.add_body(defsim::BodyDef(m1));
    const defsim::Body b = w.add_body(defsim::BodyDef(m2));
    CHECK(a != b && w.vertex_offset(a) == 0 && w.vertex_offset(b) == 8);
    CHECK(w.vertex_count() == 20);
    w.remove_body(a);
    CHECK(w.vertex_offset(b) == 0 && w.vertex_count() == 12);
    const std::vector<double> x = w.positions();
    CHECK(std::equal(x.begin(), x.end(), m2.positions().begin()));
}

// Options and statistics by name.
static void test_options_and_stats()
{
    defsim::World w(defsim::WorldDef().gravity(0, -9.81, 0));
    w.set_option("core.simd", "scalar");
    CHECK(w.option("core.simd") == 1.0);
    w.set_option("core.substep_safety", 0.5);
    w.set_option("core.auto_substep", "on");
    CHECK(w.option("core.substep_safety") == 0.5 && w.option("core.auto_substep") == 1.0);
    CHECK(throws_status(DEFSIM_ERR_INVALID_ARGUMENT, [&] { w.set_option("core.substep_safety", 2.0); }));
    CHECK(throws_status(DEFSIM_ERR_INVALID_ARGUMENT, [&] { w.set_option("core.simd", "sse2"); }));
    CHECK(throws_status(DEFSIM_ERR_INVALID_ARGUMENT, [&] { w.set_option("sundials_ida.rtol", 1e-6); }));
    CHECK(throws_status(DEFSIM_ERR_INVALID_ARGUMENT, [&] { w.option("core.nothing"); }));
    CHECK(w.option("core.substep_safety") == 0.5);
    // Options given with the def are set at creation, in order; a refused one throws.
    defsim::World wo(defsim::WorldDef().option("core.substep_safety", "0.25")
                         .option("core.auto_substep", "true")
                         .option("core.substep_safety", "0.5"));
    CHECK(wo.option("core.substep_safety") == 0.5 && wo.option("core.auto_substep") == 1.0);
    CHECK(throws_status(DEFSIM_ERR_INVALID_ARGUMENT, [&] {
        defsim::World bad(defsim::WorldDef().option("core.substep_safety", "2"));
    }));
    const double p[3] = {0, 0, 0};
    w.add_body(defsim::BodyDef().rest_positions(p).material(
        defsim::Material(defsim::Model::spring).vertex_mass(1.0)));
    for (int i = 0; i < 4; ++i) w.step(1e-3);
    const defsim_stats s = w.stats();
    CHECK(w.stat("steps") == 4.0 && w.stat("steps") == static_cast<double>(s.steps));
    CHECK(w.stat("force_evals") == static_cast<double>(s.force_evals));
    CHECK(throws_status(DEFSIM_ERR_INVALID_ARGUMENT, [&] { w.stat("nothing"); }));
}

// ---- coupling with the host ------------------------------------------------------------------

static defsim::Mesh coupling_beam() { return defsim::Mesh::box({0, 0, 0}, {0.6, 0.1, 0.1}, 3, 1, 1); }

static defsim::Material coupling_material(double damping)
{
    return defsim::Material(defsim::Model::corotated).youngs_modulus(1e5).poisson_ratio(0.3)
        .density(500).mass_damping(damping);
}

// Free body, no gravity, F_i = m_i a (held forces, then the same through a callback): after n
// symplectic Euler steps v_i = n h F_i / m_i.
static void test_external_forces()
{
    const double h = 1e-3, a[3] = {0.5, -1.0, 2.0};
    const int n = 40;
    for (int callback = 0; callback <= 1; ++callback) {
        defsim::World w(defsim::WorldDef().backend("symplectic_euler").gravity(0, 0, 0));
        const defsim::Mesh m = coupling_beam();
        w.add_body(defsim::BodyDef(m).material(coupling_material(0.0)));
        const std::vector<double> mass = w.masses();
        std::vector<double> F(3 * mass.size());
        for (std::size_t i = 0; i < mass.size(); ++i)
            for (int c = 0; c < 3; ++c) F[3 * i + c] = mass[i] * a[c];
        if (callback)
            w.set_force_callback([&F](const double *, const double *, double, int32_t k, double *f) {
                for (int32_t i = 0; i < 3 * k; ++i) f[i] += F[static_cast<std::size_t>(i)];
            });
        else
            w.set_external_forces(F);
        for (int s = 0; s < n; ++s) w.step(h);
        const std::vector<double> v = w.velocities();
        double err = 0.0;
        for (std::size_t i = 0; i < mass.size(); ++i)
            for (int c = 0; c < 3; ++c)
                err = std::max(err, std::fabs(v[3 * i + c] - n * h * F[3 * i + c] / mass[i]));
        CHECK(err < 1e-9);
    }
}

// A callback that throws: the step fails, the exception comes out of step() unchanged, and the
// state is as before; bad forces are refused.
static void test_callback_exception()
{
    defsim::World w(defsim::WorldDef().backend("symplectic_euler"));
    const defsim::Mesh m = coupling_beam();
    w.add_body(defsim::BodyDef(m).material(coupling_material(0.0)));
    int calls = 0;
    w.set_force_callback([&calls](const double *, const double *, double, int32_t, double *) {
        if (++calls > 2) throw std::runtime_error("host failed");
    });
    w.step(1e-4);
    w.step(1e-4);
    const std::vector<double> x = w.positions(), v = w.velocities();
    const double t = w.time();
    bool caught = false;
    try {
        w.step(1e-4);
    } catch (const std::runtime_error &e) {
        caught = std::string(e.what()) == "host failed";
    }
    CHECK(caught);
    CHECK(w.positions() == x && w.velocities() == v && w.time() == t);
    CHECK(w.try_step(1e-4) == DEFSIM_ERR_CALLBACK);
    w.set_force_callback(nullptr);
    w.step(1e-4);
    CHECK(w.time() > t);
    std::vector<double> bad(3 * static_cast<std::size_t>(w.vertex_count()), 0.0);
    bad[4] = std::nan("");
    CHECK(throws_status(DEFSIM_ERR_INVALID_ARGUMENT, [&] { w.set_external_forces(bad); }));
    CHECK(throws_status(DEFSIM_ERR_INVALID_ARGUMENT, [&] {
        w.set_external_forces(std::vector<double>(5, 0.0));
    }));
}

// The clamped end of a beam driven round a circle lands on each target at the end of its step.
static void test_driven_pins()
{
    defsim::World w(defsim::WorldDef().backend("symplectic_euler"));
    const defsim::Mesh m = coupling_beam();
    const defsim::Body b = w.add_body(defsim::BodyDef(m).material(coupling_material(1.0)));
    std::vector<int32_t> clamp;
    std::vector<double> rest;
    for (int32_t i = 0; i < m.vertex_count(); ++i)
        if (m.positions()[3 * static_cast<std::size_t>(i)] == 0.0) {
            clamp.push_back(i);
            for (int c = 0; c < 3; ++c) rest.push_back(m.positions()[3 * static_cast<std::size_t>(i) + c]);
        }
    double err = 0.0;
    for (int k = 1; k <= 10; ++k) {
        const double ang = 2 * 3.14159265358979323846 * k / 40;
        std::vector<double> target = rest;
        for (std::size_t j = 0; j < clamp.size(); ++j) {
            target[3 * j + 1] += 0.05 * std::sin(ang);
            target[3 * j + 2] += 0.05 * (1 - std::cos(ang));
        }
        w.set_pin_targets(b, clamp, target);
        w.step(5e-4);
        const std::vector<double> x = w.positions();
        for (std::size_t j = 0; j < clamp.size(); ++j)
            for (int c = 0; c < 3; ++c)
                err = std::max(err, std::fabs(x[3 * static_cast<std::size_t>(clamp[j]) + c] - target[3 * j + c]));
    }
    CHECK(err < 1e-12);
}

// A clamped cantilever settled with damping: its pin forces sum to minus its weight (1e-6
// relative), and an attachment's force is -k (x - p).
static void test_pin_and_attachment_forces()
{
    const double g = -9.81;
    defsim::World w(defsim::WorldDef().backend("symplectic_euler").gravity(0, g, 0));
    const defsim::Mesh m = coupling_beam();
    // Near critical damping of the first bending mode (omega_1 = 1.875^2 sqrt(EI / (rho A L^4))
    // = 4.0 rad/s): its amplitude falls by e^-24 over the 6 s.
    const defsim::Body b = w.add_body(defsim::BodyDef(m).material(coupling_material(8.0)));
    std::vector<int32_t> clamp;
    for (int32_t i = 0; i < m.vertex_count(); ++i)
        if (m.positions()[3 * static_cast<std::size_t>(i)] == 0.0) clamp.push_back(i);
    w.pin(b, clamp);
    for (int s = 0; s < 12000; ++s) w.step(5e-4);
    const std::vector<double> R = w.pin_forces(), mass = w.masses();
    double sum[3] = {0, 0, 0}, M = 0.0;
    for (std::size_t i = 0; i < mass.size(); ++i) {
        M += mass[i];
        for (int c = 0; c < 3; ++c) sum[c] += R[3 * i + c];
    }
    const double weight = M * g;
    CHECK(std::fabs(sum[1] + weight) < 1e-6 * std::fabs(weight));
    CHECK(std::fabs(sum[0]) < 1e-6 * std::fabs(weight) && std::fabs(sum[2]) < 1e-6 * std::fabs(weight));

    const std::array<double, 3> p = {0.7, 0.0, 0.05};
    const defsim::Attachment a = w.add_attachment(
        defsim::AttachmentDef().vertex(b, 1).stiffness(200.0).target(p));
    const std::vector<double> x = w.positions();
    const std::array<double, 3> f = w.attachment_force(a);
    for (int c = 0; c < 3; ++c) CHECK(std::fabs(f[static_cast<std::size_t>(c)] + 200.0 * (x[3 + static_cast<std::size_t>(c)] - p[static_cast<std::size_t>(c)])) < 1e-9);
    w.remove_attachment(a);
    CHECK(throws_status(DEFSIM_ERR_STALE_ID, [&] { w.attachment_force(a); }));
}

// The stress of a uniformly deformed tet is P F^T / J of its material, zero at rest.
static void test_element_stress()
{
    const defsim::Model models[] = {defsim::Model::stvk, defsim::Model::corotated,
                                    defsim::Model::neohookean, defsim::Model::stable_neohookean};
    for (defsim::Model model : models) {
        defsim::World w(defsim::WorldDef().gravity(0, 0, 0));
        const std::vector<double> X = {0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1};
        const std::vector<int32_t> tet = {0, 1, 2, 3};
        const defsim::Material mat = defsim::Material(model).youngs_modulus(1e5).poisson_ratio(0.3);
        const defsim::Body b = w.add_body(defsim::BodyDef().rest_positions(X).tets(tet).material(mat));
        const defsim::ElementStress rest = w.element_stress(b, 1);
        CHECK(std::all_of(rest.cauchy.begin(), rest.cauchy.end(), [](double s) { return s == 0.0; }));
        const std::array<double, 9> F = {1.2, 0.1, 0.0, 0.05, 0.9, 0.02, 0.0, -0.03, 1.1};
        std::vector<double> x(12);
        for (int v = 0; v < 4; ++v)
            for (int r = 0; r < 3; ++r)
                for (int c = 0; c < 3; ++c) x[3 * v + r] += F[3 * r + c] * X[3 * v + c];
        w.set_positions(x);
        const defsim::ElementStress s = w.element_stress(b, 1);
        const defsim::MaterialEval e = defsim::material_eval(mat, F);
        const double J = F[0] * (F[4] * F[8] - F[5] * F[7]) - F[1] * (F[3] * F[8] - F[5] * F[6]) +
                         F[2] * (F[3] * F[7] - F[4] * F[6]);
        double scale = 0.0, err = 0.0;
        for (int r = 0; r < 3; ++r)
            for (int c = 0; c < 3; ++c) {
                double sigma = 0.0;   // (P F^T)_rc / J
                for (int k = 0; k < 3; ++k) sigma += e.P[3 * r + k] * F[3 * c + k];
                sigma /= J;
                scale = std::max(scale, std::fabs(sigma));
                err = std::max(err, std::fabs(s.cauchy[static_cast<std::size_t>(3 * r + c)] - sigma));
            }
        CHECK(scale > 1e3 && err < 1e-10 * scale);
        CHECK(s.von_mises[0] > 0.0 && s.energy_density[0] > 0.0);
        CHECK(throws_status(DEFSIM_ERR_INVALID_ARGUMENT, [&] { w.element_stress(b, 2); }));
    }
}

// Stiffness by spring kind: a cloth stretched uniformly by (1 + e) stores e^2/2 sum k_kind l0^2,
// with the rest lengths summed by kind here from the mesh.
static void test_spring_kinds()
{
    const auto cloth = defsim::Mesh::cloth({0, 0, 0}, {0.6, 0, 0}, {0, 0, -0.4}, 3, 4);
    CHECK(cloth.spring_kinds().size() == static_cast<std::size_t>(cloth.spring_count()));
    const double k[3] = {300.0, 40.0, 5.0}, e = 0.02;
    double sum[3] = {0, 0, 0};
    const auto x0 = cloth.positions();
    for (int32_t s = 0; s < cloth.spring_count(); ++s) {
        const int32_t a = cloth.springs()[2 * s], b = cloth.springs()[2 * s + 1];
        double l2 = 0.0;
        for (int c = 0; c < 3; ++c) l2 += (x0[3 * a + c] - x0[3 * b + c]) * (x0[3 * a + c] - x0[3 * b + c]);
        sum[cloth.spring_kinds()[s]] += l2;
    }
    defsim::WorldDef wd;
    wd.gravity(0, 0, 0);
    defsim::World w(wd);
    w.add_body(defsim::BodyDef(cloth)
                   .material(defsim::Material(defsim::Model::spring).stiffness(k[0]).vertex_mass(0.01))
                   .shear_stiffness(k[1])
                   .bend_stiffness(k[2]));
    std::vector<double> x(x0.begin(), x0.end());
    for (double &c : x) c *= 1.0 + e;
    w.set_state(x, {});
    const double want = 0.5 * e * e * (k[0] * sum[0] + k[1] * sum[1] + k[2] * sum[2]);
    CHECK(std::fabs(w.energy().elastic - want) < 1e-12 * want);
    // Per-spring stiffness replaces the kinds instead of conflicting with them.
    std::vector<double> ks(static_cast<std::size_t>(cloth.spring_count()), 7.0);
    w.add_body(defsim::BodyDef(cloth).spring_stiffness(ks).material(
        defsim::Material(defsim::Model::spring).vertex_mass(0.01)));
    CHECK(w.vertex_count() == 2 * cloth.vertex_count());
}

// Colliders: add, list, pose, remove, contact forces' shape, and errors as exceptions.
static void test_colliders()
{
    defsim::World w;
    const std::vector<double> p = {0, 1, 0};
    w.add_body(defsim::BodyDef().rest_positions(p).material(
        defsim::Material(defsim::Model::spring).vertex_mass(1.0)));
    const auto ball = w.add_collider(defsim::ColliderDef(defsim::Shape::sphere).radius(0.5)
                                         .position({0, -1, 0}).friction(0.2));
    const auto ground = w.add_collider(defsim::ColliderDef());
    CHECK(!ball.is_null() && !(ball == ground));
    CHECK(w.colliders().size() == 2 && w.colliders()[0] == ball);
    const defsim_collider_def d = w.collider_def(ball);
    CHECK(d.shape == DEFSIM_SHAPE_SPHERE && d.radius == 0.5 && d.position[1] == -1.0 && d.friction == 0.2);
    w.set_collider_pose(ball, {0, -0.5, 0});
    CHECK(w.contact_forces().size() == 3);
    CHECK(throws_status(DEFSIM_ERR_INVALID_ARGUMENT, [&] {
        w.add_collider(defsim::ColliderDef(defsim::Shape::sphere).radius(-1.0));
    }));
    CHECK(throws_status(DEFSIM_ERR_INVALID_ARGUMENT, [&] { w.set_collider_pose(ball, {0, 0, 0}, {2, 0, 0, 0}); }));
    w.remove_collider(ball);
    CHECK(w.colliders().size() == 1);
    CHECK(throws_status(DEFSIM_ERR_STALE_ID, [&] { w.remove_collider(ball); }));
    CHECK(throws_status(DEFSIM_ERR_STALE_ID, [&] { w.collider_def(ball); }));
}

int main()
{
    test_version();
    test_mesh();
    test_free_fall();
    test_matches_c();
    test_errors();
    test_moves_and_log();
    test_material_eval();
    test_energy_forces();
    test_bodies();
    test_options_and_stats();
    test_external_forces();
    test_callback_exception();
    test_driven_pins();
    test_pin_and_attachment_forces();
    test_element_stress();
    test_spring_kinds();
    test_colliders();
    if (failures) std::fprintf(stderr, "%d check(s) failed\n", failures);
    return failures ? 1 : 0;
}
