// SPDX-License-Identifier: MIT
/// @file
/// defsim.hpp: a header-only C++17 wrapper over the C API in defsim/defsim.h.
//
// It adds no ABI of its own: every call goes to a defsim_* function of libdefsim, so a host
// links libdefsim exactly as a C host does. What it adds:
//  - RAII ownership: World and Mesh free what they own; both are move-only.
//  - Exceptions: a failed call throws defsim::Error, which carries the status code and the
//    library's detail message. World::try_step is the non-throwing way to step (a game loop
//    that treats DEFSIM_ERR_UNSTABLE as a signal to shrink its step, for instance).
//  - Checked array sizes: arrays are passed as defsim::Span (pointer and size; std::vector,
//    std::array, C arrays and std::span convert implicitly), and sizes are checked against the
//    world's vertex count before the C call, which cannot check them itself.
//  - Builders: Material, WorldDef and BodyDef start from the library's defaults
//    (defsim_*_init) and set fields with chained calls.
//
// Thread safety is that of the C API: a World is used from one thread at a time.
#ifndef DEFSIM_DEFSIM_HPP
#define DEFSIM_DEFSIM_HPP

#include <defsim/defsim.h>

#include <array>
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <exception>
#include <functional>
#include <limits>
#include <memory>
#include <stdexcept>
#include <string>
#include <type_traits>
#include <utility>
#include <vector>

namespace defsim {

/// The exception thrown by every wrapper call that fails. what() is "<status text>: <detail>".
class Error : public std::runtime_error {
public:
    /// Makes an error for status code `status` with the library's (or the wrapper's) detail.
    Error(defsim_status status, const std::string &message)
        : std::runtime_error(std::string(defsim_status_string(status)) +
                             (message.empty() ? "" : ": " + message)),
          status_(status), message_(message)
    {
    }
    /// The status code (a negative DEFSIM_ERR_* value).
    defsim_status status() const noexcept { return status_; }
    /// The detail message alone (defsim_world_last_error / defsim_last_error at the time).
    const std::string &message() const noexcept { return message_; }

private:
    defsim_status status_;
    std::string message_;
};

namespace detail {

/// Throws for a failed call that has no world (defsim_last_error holds the detail).
inline void check(defsim_status status)
{
    if (status < 0) throw Error(status, defsim_last_error());
}

/// Throws for a failed call on `world`.
inline void check(defsim_status status, const defsim_world *world)
{
    if (status < 0) throw Error(status, defsim_world_last_error(world));
}

/// Throws DEFSIM_ERR_INVALID_ARGUMENT with a message of the wrapper's own.
[[noreturn]] inline void invalid(const std::string &message)
{
    throw Error(DEFSIM_ERR_INVALID_ARGUMENT, message);
}

/// A size as the int32_t counts of the C API, or an error.
inline int32_t count(std::size_t n, const char *what)
{
    if (n > static_cast<std::size_t>(std::numeric_limits<int32_t>::max()))
        invalid(std::string(what) + ": too many elements for the C API");
    return static_cast<int32_t>(n);
}

template <class C, class T, class = void>
struct is_container_of : std::false_type {};
template <class C, class T>
struct is_container_of<C, T,
    std::void_t<decltype(std::declval<C &>().data()), decltype(std::declval<C &>().size())>>
    : std::is_convertible<decltype(std::declval<C &>().data()), T *> {};

}  // namespace detail

/// A non-owning view of contiguous elements: a pointer and a count, like C++20's std::span
/// (which converts to it). Valid while what it views is alive and unchanged in size.
template <class T>
class Span {
public:
    using element_type = T;                     ///< The element type, as viewed.
    using value_type = std::remove_cv_t<T>;     ///< The element type without const.
    using size_type = std::size_t;              ///< The type of sizes.
    using iterator = T *;                       ///< A pointer into the view.

    /// An empty view.
    constexpr Span() noexcept = default;
    /// A view of `size` elements at `data`.
    constexpr Span(T *data, std::size_t size) noexcept : data_(data), size_(size) {}
    /// A view of a C array.
    template <std::size_t N>
    constexpr Span(T (&array)[N]) noexcept : data_(array), size_(N) {}
    /// A view of a container with data() and size() (std::vector, std::array, std::span).
    template <class C, std::enable_if_t<detail::is_container_of<C, T>::value &&
                                        !std::is_same<std::decay_t<C>, Span>::value, int> = 0>
    constexpr Span(C &container) noexcept : data_(container.data()), size_(container.size()) {}
    /// A read-only view of a const container (also a temporary: only for the call it is passed to).
    template <class C, std::enable_if_t<std::is_const<T>::value &&
                                        detail::is_container_of<const C, T>::value &&
                                        !std::is_same<std::decay_t<C>, Span>::value, int> = 0>
    constexpr Span(const C &container) noexcept : data_(container.data()), size_(container.size()) {}
    /// A read-only view of a writable view.
    template <class U, std::enable_if_t<std::is_convertible<U *, T *>::value &&
                                        !std::is_same<U, T>::value, int> = 0>
    constexpr Span(Span<U> other) noexcept : data_(other.data()), size_(other.size()) {}

    /// The first element (nullptr for an empty view).
    constexpr T *data() const noexcept { return data_; }
    /// The number of elements.
    constexpr std::size_t size() const noexcept { return size_; }
    /// True when size() is 0.
    constexpr bool empty() const noexcept { return size_ == 0; }
    /// Element i (unchecked: i < size()).
    constexpr T &operator[](std::size_t i) const noexcept { return data_[i]; }
    /// Iteration from data()...
    constexpr T *begin() const noexcept { return data_; }
    /// ... to data() + size().
    constexpr T *end() const noexcept { return data_ + size_; }

private:
    T *data_ = nullptr;
    std::size_t size_ = 0;
};

/// Constitutive models (defsim_model).
enum class Model : int {
    spring = DEFSIM_MODEL_SPRING,
    stvk = DEFSIM_MODEL_STVK,
    corotated = DEFSIM_MODEL_COROTATED,
    neohookean = DEFSIM_MODEL_NEOHOOKEAN,
    stable_neohookean = DEFSIM_MODEL_STABLE_NEOHOOKEAN
};

/// Hessian projection of implicit backends (defsim_projection).
enum class Projection : int {
    none = DEFSIM_PROJECTION_NONE,
    clamp = DEFSIM_PROJECTION_CLAMP,
    abs = DEFSIM_PROJECTION_ABS,
    automatic = DEFSIM_PROJECTION_AUTO   ///< "auto" (a C++ keyword)
};

/// The library's version number (major * 10000 + minor * 100 + patch).
inline int32_t library_version() noexcept { return defsim_version_number(); }

/// True if the linked library can serve this header: same major version, at least as new.
inline bool library_compatible() noexcept
{
    const int32_t v = defsim_version_number();
    return v / 10000 == DEFSIM_VERSION_NUMBER / 10000 && v >= DEFSIM_VERSION_NUMBER;
}

/// Material parameters (defsim_material), SI units, starting from the model's defaults.
/// Setters return *this; the library checks the values when the material is used.
class Material {
public:
    /// The defaults of `model` (defsim_material_init).
    explicit Material(Model model = Model::stable_neohookean) noexcept
    {
        defsim_material_init(&m_, sizeof m_, static_cast<defsim_model>(model));
    }
    /// Wraps a C material (its size must be set, e.g. by defsim_material_init).
    explicit Material(const defsim_material &m) noexcept : m_(m) {}

    /// The constitutive model (set at construction).
    Model model() const noexcept { return static_cast<Model>(m_.model); }
    /// Young's modulus E in Pa (tet models).
    Material &youngs_modulus(double E) noexcept { m_.youngs_modulus = E; return *this; }
    /// Poisson ratio nu in [0, 0.5) (tet models).
    Material &poisson_ratio(double nu) noexcept { m_.poisson_ratio = nu; return *this; }
    /// Density in kg/m^3 (lumped tet masses).
    Material &density(double rho) noexcept { m_.density = rho; return *this; }
    /// Spring stiffness k in N/m for every spring of the body.
    Material &stiffness(double k) noexcept { m_.stiffness = k; return *this; }
    /// Mass in kg added to every vertex of the body.
    Material &vertex_mass(double m) noexcept { m_.vertex_mass = m; return *this; }
    /// Rayleigh alpha in 1/s (damping force -alpha M v).
    Material &mass_damping(double alpha) noexcept { m_.mass_damping = alpha; return *this; }
    /// Rayleigh beta in s (damping force -beta K(x) v).
    Material &stiffness_damping(double beta) noexcept { m_.stiffness_damping = beta; return *this; }

    double youngs_modulus() const noexcept { return m_.youngs_modulus; }   ///< E, Pa.
    double poisson_ratio() const noexcept { return m_.poisson_ratio; }     ///< nu.
    double density() const noexcept { return m_.density; }                 ///< kg/m^3.
    double stiffness() const noexcept { return m_.stiffness; }             ///< k, N/m.
    double vertex_mass() const noexcept { return m_.vertex_mass; }         ///< kg.
    double mass_damping() const noexcept { return m_.mass_damping; }       ///< alpha, 1/s.
    double stiffness_damping() const noexcept { return m_.stiffness_damping; }   ///< beta, s.

    /// The C struct.
    const defsim_material &c_struct() const noexcept { return m_; }

private:
    defsim_material m_;
};

/// Result of material_eval: energy density (J/m^3), first Piola-Kirchhoff stress (row-major,
/// Pa) and its derivative, dPdF[9 * (3 i + j) + (3 k + l)] = dP_ij / dF_kl.
struct MaterialEval {
    double psi = 0.0;                  ///< Energy density, J/m^3.
    std::array<double, 9> P{};         ///< First Piola-Kirchhoff stress, row-major, Pa.
    std::array<double, 81> dPdF{};     ///< dP_ij / dF_kl at 9 * (3 i + j) + (3 k + l).
};

/// Evaluates a tet material at a deformation gradient F (row-major) with defsim_material_eval.
/// Throws Error: DEFSIM_ERR_INVALID_ARGUMENT (spring model, non-finite F),
/// DEFSIM_ERR_INVALID_MATERIAL, DEFSIM_ERR_UNSTABLE (neo-Hookean at det F <= 0).
inline MaterialEval material_eval(const Material &material, const std::array<double, 9> &F)
{
    MaterialEval r;
    detail::check(defsim_material_eval(&material.c_struct(), F.data(), &r.psi, r.P.data(),
                                       r.dPdF.data()));
    return r;
}

/// A mesh whose arrays the library allocated (defsim_mesh); freed by the destructor. Move-only.
class Mesh {
public:
    /// An empty mesh.
    Mesh() noexcept { clear(); }
    ~Mesh() { defsim_mesh_free(&m_); }
    Mesh(const Mesh &) = delete;
    Mesh &operator=(const Mesh &) = delete;
    /// Takes other's arrays; other is left empty.
    Mesh(Mesh &&other) noexcept : m_(other.m_) { other.clear(); }
    /// Frees this mesh's arrays and takes other's; other is left empty.
    Mesh &operator=(Mesh &&other) noexcept
    {
        if (this != &other) {
            defsim_mesh_free(&m_);
            m_ = other.m_;
            other.clear();
        }
        return *this;
    }

    /// Takes ownership of a mesh filled by a defsim_mesh_* function (the argument is left empty).
    static Mesh adopt(defsim_mesh &mesh) noexcept
    {
        Mesh r;
        r.m_ = mesh;
        r.m_.size = sizeof r.m_;
        std::memset(&mesh, 0, sizeof mesh);
        mesh.size = sizeof mesh;
        return r;
    }

    /// A box of nx * ny * nz cells on [lo, hi], 6 tets per cell, with its boundary triangles
    /// (defsim_mesh_box). Throws Error (DEFSIM_ERR_INVALID_ARGUMENT, DEFSIM_ERR_OUT_OF_MEMORY).
    static Mesh box(const std::array<double, 3> &lo, const std::array<double, 3> &hi, int32_t nx,
                    int32_t ny, int32_t nz)
    {
        Mesh r;
        detail::check(defsim_mesh_box(lo.data(), hi.data(), nx, ny, nz, &r.m_));
        return r;
    }

    /// A cloth grid (defsim_mesh_cloth): (nu + 1) x (nv + 1) vertices at origin + i/nu u + j/nv v
    /// (m), triangles, and stretch, shear and bend springs (spring_kinds()). Throws Error
    /// (DEFSIM_ERR_INVALID_ARGUMENT, DEFSIM_ERR_OUT_OF_MEMORY).
    static Mesh cloth(const std::array<double, 3> &origin, const std::array<double, 3> &u,
                      const std::array<double, 3> &v, int32_t nu, int32_t nv)
    {
        Mesh r;
        detail::check(defsim_mesh_cloth(origin.data(), u.data(), v.data(), nu, nv, &r.m_));
        return r;
    }
    /// A rope from a to b (defsim_mesh_rope): links, then bending springs. Throws Error.
    static Mesh rope(const std::array<double, 3> &a, const std::array<double, 3> &b,
                     int32_t segments)
    {
        Mesh r;
        detail::check(defsim_mesh_rope(a.data(), b.data(), segments, &r.m_));
        return r;
    }

    int32_t vertex_count() const noexcept { return m_.vertex_count; }       ///< Vertices.
    int32_t tet_count() const noexcept { return m_.tet_count; }             ///< Tets.
    /// Indices per tet: 4, or 10 for quadratic tets (defsim_body_def.tet_nodes).
    int32_t tet_nodes() const noexcept { return m_.tet_nodes == 10 ? 10 : 4; }
    /// Turns the linear tets quadratic (defsim_mesh_make_quadratic: a vertex at every edge's
    /// middle, 10 indices per tet). Throws Error (DEFSIM_ERR_INVALID_ARGUMENT: no tets, or
    /// quadratic already; DEFSIM_ERR_OUT_OF_MEMORY).
    Mesh &make_quadratic()
    {
        detail::check(defsim_mesh_make_quadratic(&m_));
        return *this;
    }
    int32_t triangle_count() const noexcept { return m_.triangle_count; }   ///< Triangles.
    int32_t spring_count() const noexcept { return m_.spring_count; }       ///< Springs.
    /// 3 * vertex_count() coordinates (m).
    Span<const double> positions() const noexcept
    {
        return {m_.positions, 3 * static_cast<std::size_t>(m_.vertex_count)};
    }
    /// tet_nodes() vertex indices per tet.
    Span<const int32_t> tets() const noexcept
    {
        return {m_.tets, static_cast<std::size_t>(tet_nodes()) * static_cast<std::size_t>(m_.tet_count)};
    }
    /// 3 vertex indices per triangle (outward boundary of the tets, or cloth faces).
    Span<const int32_t> triangles() const noexcept
    {
        return {m_.triangles, 3 * static_cast<std::size_t>(m_.triangle_count)};
    }
    /// 2 vertex indices per spring.
    Span<const int32_t> springs() const noexcept
    {
        return {m_.springs, 2 * static_cast<std::size_t>(m_.spring_count)};
    }
    /// One defsim_spring_kind per spring (cloth and rope meshes); empty: all stretch springs.
    Span<const int32_t> spring_kinds() const noexcept
    {
        if (!m_.spring_kinds) return {};
        return {m_.spring_kinds, static_cast<std::size_t>(m_.spring_count)};
    }
    /// The C struct (still owned by this Mesh).
    const defsim_mesh &c_struct() const noexcept { return m_; }

private:
    void clear() noexcept
    {
        std::memset(&m_, 0, sizeof m_);
        m_.size = sizeof m_;
    }
    defsim_mesh m_;
};

namespace detail {

/// What Body and Attachment share: a small value around a C id {index, generation}, not a
/// pointer. The default is the null id.
template <class Id, class Self>
class Handle {
public:
    constexpr Handle() noexcept = default;
    /// Wraps a C id.
    constexpr explicit Handle(Id id) noexcept : id_(id) {}
    /// The C id.
    constexpr Id id() const noexcept { return id_; }
    /// The id's slot (with its world's tag).
    constexpr uint32_t index() const noexcept { return id_.index; }
    /// The id's generation.
    constexpr uint32_t generation() const noexcept { return id_.generation; }
    /// True for the null id {0, 0}.
    constexpr bool is_null() const noexcept { return id_.index == 0 && id_.generation == 0; }
    /// The same id.
    friend constexpr bool operator==(Self a, Self b) noexcept
    {
        return a.id_.index == b.id_.index && a.id_.generation == b.id_.generation;
    }
    /// Different ids.
    friend constexpr bool operator!=(Self a, Self b) noexcept { return !(a == b); }

private:
    Id id_{0, 0};
};

}  // namespace detail

/// A body handle (defsim_body_id): a small value, not a pointer. The default is the null id.
class Body : public detail::Handle<defsim_body_id, Body> {
public:
    using Handle::Handle;
};

/// Creation parameters of a body (defsim_body_def). The arrays are NOT copied here: they must
/// stay alive until World::add_body returns (which copies them). Setters return *this.
class BodyDef {
public:
    /// No geometry, stable neo-Hookean defaults (defsim_body_def_init).
    BodyDef() noexcept { defsim_body_def_init(&d_, sizeof d_); }
    /// The positions, tets and springs of a mesh (which must outlive add_body).
    explicit BodyDef(const Mesh &mesh) : BodyDef()
    {
        rest_positions(mesh.positions());
        tets(mesh.tets(), mesh.tet_nodes());
        springs(mesh.springs());
        spring_kinds(mesh.spring_kinds());
    }

    /// Rest positions, 3 per vertex (m). Sets the vertex count.
    BodyDef &rest_positions(Span<const double> xyz)
    {
        if (xyz.size() % 3 != 0) detail::invalid("rest_positions: size is not a multiple of 3");
        d_.rest_positions = xyz.data();
        d_.vertex_count = detail::count(xyz.size() / 3, "rest_positions");
        return *this;
    }
    /// Tets, `nodes` body-local vertex indices each: 4, or 10 for quadratic tets (the corners,
    /// then the mid-edge nodes of edges 01, 12, 02, 03, 13, 23; defsim_body_def.tet_nodes).
    BodyDef &tets(Span<const int32_t> idx, int32_t nodes = 4)
    {
        if (nodes != 4 && nodes != 10) detail::invalid("tets: nodes must be 4 or 10");
        if (idx.size() % static_cast<std::size_t>(nodes) != 0)
            detail::invalid("tets: size is not a multiple of the nodes per tet");
        d_.tets = idx.empty() ? nullptr : idx.data();
        d_.tet_count = detail::count(idx.size() / static_cast<std::size_t>(nodes), "tets");
        d_.tet_nodes = nodes;
        return *this;
    }
    /// Springs, 2 body-local vertex indices each.
    BodyDef &springs(Span<const int32_t> idx)
    {
        if (idx.size() % 2 != 0) detail::invalid("springs: size is not a multiple of 2");
        d_.springs = idx.empty() ? nullptr : idx.data();
        d_.spring_count = detail::count(idx.size() / 2, "springs");
        return *this;
    }
    /// One stiffness (N/m) per spring; empty: material.stiffness for all. A non-empty one
    /// replaces the spring kinds (a mesh's, or spring_kinds()).
    BodyDef &spring_stiffness(Span<const double> k) noexcept
    {
        d_.spring_stiffness = k.empty() ? nullptr : k.data();
        n_k_ = k.size();
        if (!k.empty()) {
            d_.spring_kinds = nullptr;
            n_kinds_ = 0;
        }
        return *this;
    }
    /// One defsim_spring_kind per spring (a cloth or rope Mesh sets them); stretch springs take
    /// material.stiffness, shear and bend springs shear_stiffness() and bend_stiffness().
    /// Not together with spring_stiffness (add_body throws DEFSIM_ERR_INVALID_ARGUMENT).
    BodyDef &spring_kinds(Span<const int32_t> kinds) noexcept
    {
        d_.spring_kinds = kinds.empty() ? nullptr : kinds.data();
        n_kinds_ = kinds.size();
        return *this;
    }
    /// Stiffness of shear springs (N/m); negative (the default): material.stiffness.
    BodyDef &shear_stiffness(double k) noexcept { d_.shear_stiffness = k; return *this; }
    /// Stiffness of bend springs (N/m); negative (the default): material.stiffness.
    BodyDef &bend_stiffness(double k) noexcept { d_.bend_stiffness = k; return *this; }
    /// One mass (kg) per vertex; empty: lumped from density plus material.vertex_mass.
    BodyDef &vertex_mass(Span<const double> m) noexcept
    {
        d_.vertex_mass = m.empty() ? nullptr : m.data();
        n_m_ = m.size();
        return *this;
    }
    /// Initial positions, 3 per vertex; empty: the rest positions.
    BodyDef &initial_positions(Span<const double> x) noexcept
    {
        d_.initial_positions = x.empty() ? nullptr : x.data();
        n_x_ = x.size();
        return *this;
    }
    /// Initial velocities, 3 per vertex (m/s); empty: zero.
    BodyDef &initial_velocities(Span<const double> v) noexcept
    {
        d_.initial_velocities = v.empty() ? nullptr : v.data();
        n_v_ = v.size();
        return *this;
    }
    /// The body's material.
    BodyDef &material(const Material &m) noexcept
    {
        d_.material = m.c_struct();
        return *this;
    }

    /// Throws DEFSIM_ERR_INVALID_ARGUMENT if an optional array's size does not match the counts.
    void check_sizes() const
    {
        const std::size_t nv = static_cast<std::size_t>(d_.vertex_count);
        if (d_.spring_stiffness && n_k_ != static_cast<std::size_t>(d_.spring_count))
            detail::invalid("spring_stiffness: needs one value per spring");
        if (d_.spring_kinds && n_kinds_ != static_cast<std::size_t>(d_.spring_count))
            detail::invalid("spring_kinds: needs one value per spring");
        if (d_.vertex_mass && n_m_ != nv) detail::invalid("vertex_mass: needs one value per vertex");
        if (d_.initial_positions && n_x_ != 3 * nv)
            detail::invalid("initial_positions: needs 3 values per vertex");
        if (d_.initial_velocities && n_v_ != 3 * nv)
            detail::invalid("initial_velocities: needs 3 values per vertex");
    }
    /// The C struct (pointing into the caller's arrays).
    const defsim_body_def &c_struct() const noexcept { return d_; }

private:
    defsim_body_def d_;
    std::size_t n_k_ = 0, n_m_ = 0, n_x_ = 0, n_v_ = 0, n_kinds_ = 0;
};

/// A log sink: level 0 error, 1 warning, 2 info, 3 debug; the message is borrowed for the call.
/// It must not throw (an exception it throws is swallowed: it cannot cross the C library).
using LogFunction = std::function<void(int level, const char *message)>;

/// Creation parameters of a world (defsim_world_def), starting from the library's defaults.
class WorldDef {
public:
    WorldDef()
    {
        defsim_world_def_init(&d_, sizeof d_);
        backend_ = d_.backend ? d_.backend : "";
    }
    /// Backend name ("explicit_euler", "symplectic_euler", "newton_cholmod", ...).
    WorldDef &backend(std::string name)
    {
        backend_ = std::move(name);
        return *this;
    }
    /// Gravity in m/s^2.
    WorldDef &gravity(double x, double y, double z) noexcept
    {
        d_.gravity[0] = x;
        d_.gravity[1] = y;
        d_.gravity[2] = z;
        return *this;
    }
    /// Threads for assembly; 0: OpenMP's default.
    WorldDef &num_threads(int32_t n) noexcept { d_.num_threads = n; return *this; }
    /// An option by name, set by World's constructor right after creation, in the order given
    /// (World::set_option): a backend's settings ("newton_cholmod.tolerance" = "1e-8",
    /// "sundials_ida.rtol", "newton_cholmod.projection" = "abs") and the core's
    /// ("core.auto_substep" = "true"). A name or value the world refuses makes the constructor
    /// throw (Error DEFSIM_ERR_INVALID_ARGUMENT).
    WorldDef &option(std::string name, std::string value)
    {
        options_.emplace_back(std::move(name), std::move(value));
        return *this;
    }
    /// A log sink (see LogFunction); empty: silent.
    WorldDef &log(LogFunction fn)
    {
        log_ = std::move(fn);
        return *this;
    }

    /// The backend name set by backend() (empty: the library's default).
    const std::string &backend() const noexcept { return backend_; }
    /// The log function set by log() (empty: none).
    const LogFunction &log() const noexcept { return log_; }
    /// The options by name that World's constructor sets, in order.
    const std::vector<std::pair<std::string, std::string>> &options() const noexcept
    {
        return options_;
    }
    /// The C struct, without the log sink; its backend pointer is valid while *this lives.
    defsim_world_def c_struct() const noexcept
    {
        defsim_world_def d = d_;
        d.backend = backend_.c_str();
        d.log = nullptr;
        d.log_user = nullptr;
        return d;
    }

private:
    defsim_world_def d_;
    std::string backend_;
    LogFunction log_;
    std::vector<std::pair<std::string, std::string>> options_;
};

/// An owning world handle (defsim_world). Move-only; a moved-from World is empty, and calls on
/// it throw DEFSIM_ERR_INVALID_ARGUMENT.
/// An attachment handle (defsim_attachment_id): a small value like Body. The default is null.
class Attachment : public detail::Handle<defsim_attachment_id, Attachment> {
public:
    using Handle::Handle;
};

/// A collider handle (defsim_collider_id): a small value like Body. The default is null.
class Collider : public detail::Handle<defsim_collider_id, Collider> {
public:
    using Handle::Handle;
};

/// Collider shapes (defsim_shape).
enum class Shape : int {
    plane = DEFSIM_SHAPE_PLANE,
    sphere = DEFSIM_SHAPE_SPHERE,
    box = DEFSIM_SHAPE_BOX,
    capsule = DEFSIM_SHAPE_CAPSULE,
    mesh = DEFSIM_SHAPE_MESH,
    sdf = DEFSIM_SHAPE_SDF
};

/// Creation parameters of a collider (defsim_collider_def), from the library's defaults (a
/// ground plane through the origin, normal +y, no friction). Mesh arrays are NOT copied here:
/// they must stay alive until World::add_collider returns. Setters return *this.
class ColliderDef {
public:
    /// The library's defaults (defsim_collider_def_init) for a collider of this shape.
    explicit ColliderDef(Shape shape = Shape::plane) noexcept
    {
        defsim_collider_def_init(&d_, sizeof d_);
        d_.shape = static_cast<defsim_shape>(shape);
    }
    /// Origin of the collider's frame in the world (m).
    ColliderDef &position(const std::array<double, 3> &p) noexcept { set3(d_.position, p); return *this; }
    /// Unit quaternion (w, x, y, z) from the local frame to the world.
    ColliderDef &rotation(const std::array<double, 4> &q) noexcept
    {
        for (int i = 0; i < 4; ++i) d_.rotation[i] = q[static_cast<std::size_t>(i)];
        return *this;
    }
    ColliderDef &normal(const std::array<double, 3> &n) noexcept { set3(d_.normal, n); return *this; }   ///< plane
    ColliderDef &radius(double r) noexcept { d_.radius = r; return *this; }              ///< sphere, capsule (m)
    ColliderDef &half_extents(const std::array<double, 3> &h) noexcept { set3(d_.half_extents, h); return *this; }  ///< box (m)
    ColliderDef &half_height(double h) noexcept { d_.half_height = h; return *this; }    ///< capsule (m)
    ColliderDef &friction(double mu) noexcept { d_.friction = mu; return *this; }        ///< Coulomb mu >= 0
    /// A mesh collider's vertices (3 per vertex, m, local frame) and triangles (3 indices each).
    ColliderDef &mesh(Span<const double> vertices, Span<const int32_t> triangles)
    {
        if (vertices.size() % 3 != 0 || triangles.size() % 3 != 0)
            detail::invalid("collider mesh: sizes are not multiples of 3");
        d_.vertices = vertices.empty() ? nullptr : vertices.data();
        d_.vertex_count = detail::count(vertices.size() / 3, "collider vertices");
        d_.triangles = triangles.empty() ? nullptr : triangles.data();
        d_.triangle_count = detail::count(triangles.size() / 3, "collider triangles");
        return *this;
    }
    /// The C struct (pointing into the caller's arrays).
    const defsim_collider_def &c_struct() const noexcept { return d_; }

private:
    static void set3(double *dst, const std::array<double, 3> &a) noexcept
    {
        dst[0] = a[0]; dst[1] = a[1]; dst[2] = a[2];
    }
    defsim_collider_def d_;
};

/// Creation parameters of an attachment (defsim_attachment_def), from the library's defaults.
/// Setters return *this.
class AttachmentDef {
public:
    AttachmentDef() noexcept { defsim_attachment_def_init(&d_, sizeof d_); }
    /// The attached vertex: body-local index `vertex` of `body`.
    AttachmentDef &vertex(Body body, int32_t vertex) noexcept
    {
        d_.body = body.id();
        d_.vertex = vertex;
        return *this;
    }
    AttachmentDef &stiffness(double k) noexcept { d_.stiffness = k; return *this; }   ///< N/m
    AttachmentDef &damping(double c) noexcept { d_.damping = c; return *this; }       ///< N s/m
    /// A world point (m) as the target.
    AttachmentDef &target(const std::array<double, 3> &p) noexcept
    {
        d_.target_body = defsim_body_id{0, 0};
        d_.target_vertex_count = 0;
        for (int i = 0; i < 3; ++i) d_.target[i] = p[i];
        return *this;
    }
    /// The point sum_j weights[j] x[vertices[j]] of `body` (1 to 4 body-local vertices, weights
    /// summing to 1) as the target. Throws DEFSIM_ERR_INVALID_ARGUMENT for other sizes.
    AttachmentDef &target(Body body, Span<const int32_t> vertices, Span<const double> weights)
    {
        if (vertices.size() < 1 || vertices.size() > 4 || weights.size() != vertices.size())
            detail::invalid("attachment target: 1 to 4 vertices with one weight each");
        d_.target_body = body.id();
        d_.target_vertex_count = static_cast<int32_t>(vertices.size());
        for (std::size_t j = 0; j < vertices.size(); ++j) {
            d_.target_vertices[j] = vertices.data()[j];
            d_.target_weights[j] = weights.data()[j];
        }
        return *this;
    }
    /// The C struct.
    const defsim_attachment_def &c_struct() const noexcept { return d_; }

private:
    defsim_attachment_def d_;
};

/// Per-tet stress of a body (World::element_stress), in the order of its tets.
struct ElementStress {
    std::vector<double> cauchy;          ///< 9 per tet, row-major, Pa
    std::vector<double> von_mises;       ///< 1 per tet, Pa
    std::vector<double> energy_density;  ///< 1 per tet, J/m^3 relative to rest
};

/// A force callback: adds forces (N) into f (3 n doubles, already holding the world's other
/// forces) at positions x (m), velocities v (m/s), time t (s). It may throw: the exception is
/// caught at the C boundary, the step fails with the state unchanged, and World::step rethrows
/// it (see World::set_force_callback).
using ForceFunction =
    std::function<void(const double *x, const double *v, double t, int32_t n, double *f)>;
/// Its optional Jacobian (the same signature): writes into its last argument 9 n doubles, the
/// row-major blocks dF_i/dx_i (N/m).
using ForceJacobianFunction = ForceFunction;

/// A world (defsim_world) and what it owns: move-only, destroyed with the object. Calls that
/// fail throw Error with the library's status and detail.
class World {
public:
    /// Creates a world (defsim_world_create). Throws Error: DEFSIM_ERR_BACKEND_UNAVAILABLE,
    /// DEFSIM_ERR_INVALID_ARGUMENT, DEFSIM_ERR_OUT_OF_MEMORY.
    explicit World(const WorldDef &def = WorldDef())
    {
        defsim_world_def d = def.c_struct();
        if (def.log()) {
            // The sink lives on the heap so that its address survives moves of the World.
            log_ = std::make_unique<LogFunction>(def.log());
            d.log = &World::log_trampoline;
            d.log_user = log_.get();
        }
        detail::check(defsim_world_create(&d, &w_));
        for (const auto &o : def.options()) {
            const defsim_status st = defsim_world_set_option(w_, o.first.c_str(), o.second.c_str());
            if (st != DEFSIM_OK) {
                const std::string what = defsim_world_last_error(w_);
                defsim_world_destroy(w_);
                w_ = nullptr;
                throw Error(st, what);
            }
        }
    }
    /// Takes ownership of a world made with the C API.
    explicit World(defsim_world *adopt) noexcept : w_(adopt) {}
    ~World() { defsim_world_destroy(w_); }
    World(const World &) = delete;
    World &operator=(const World &) = delete;
    /// Takes other's world; other is left empty (operator bool false).
    World(World &&other) noexcept
        : w_(other.w_), log_(std::move(other.log_)), force_(std::move(other.force_))
    {
        other.w_ = nullptr;
    }
    /// Destroys this world and takes other's; other is left empty.
    World &operator=(World &&other) noexcept
    {
        if (this != &other) {
            defsim_world_destroy(w_);
            w_ = other.w_;
            log_ = std::move(other.log_);
            force_ = std::move(other.force_);
            other.w_ = nullptr;
        }
        return *this;
    }

    /// The C handle (still owned by this World), or nullptr if empty.
    defsim_world *get() const noexcept { return w_; }
    /// Gives up ownership: the caller destroys the returned world with defsim_world_destroy.
    /// The wrapper's log sink and force callback, which this World owns, are detached from the
    /// world and freed: the returned world is silent and has no force callback (set new ones
    /// with defsim_world_set_log and defsim_world_set_force_callback).
    defsim_world *release() noexcept
    {
        defsim_world *w = w_;
        w_ = nullptr;
        if (w && log_) (void)defsim_world_set_log(w, nullptr, nullptr);
        if (w && force_) (void)defsim_world_set_force_callback(w, nullptr, nullptr, nullptr);
        log_.reset();
        force_.reset();
        return w;
    }
    /// True while the object holds a world (not moved from, not released).
    explicit operator bool() const noexcept { return w_ != nullptr; }

    /// Adds a body (defsim_world_add_body); the arrays of `def` are copied. Throws Error:
    /// DEFSIM_ERR_INVALID_ARGUMENT, DEFSIM_ERR_INVALID_MESH, DEFSIM_ERR_INVALID_MATERIAL, ...
    Body add_body(const BodyDef &def)
    {
        def.check_sizes();
        defsim_body_id id{0, 0};
        check(defsim_world_add_body(w_, &def.c_struct(), &id));
        return Body(id);
    }
    /// Removes a body; later bodies' vertices move down. Throws DEFSIM_ERR_STALE_ID.
    void remove_body(Body body) { check(defsim_world_remove_body(w_, body.id())); }
    /// Pins body-local vertices where they are now. Throws DEFSIM_ERR_INVALID_ARGUMENT (index
    /// out of range), DEFSIM_ERR_STALE_ID.
    void pin(Body body, Span<const int32_t> vertices)
    {
        check(defsim_body_pin(w_, body.id(), vertices.data(),
                              detail::count(vertices.size(), "vertices")));
    }
    /// Unpins body-local vertices. Same errors as pin.
    void unpin(Body body, Span<const int32_t> vertices)
    {
        check(defsim_body_unpin(w_, body.id(), vertices.data(),
                                detail::count(vertices.size(), "vertices")));
    }
    /// Vertices of one body. Throws DEFSIM_ERR_STALE_ID.
    int32_t vertex_count(Body body) const
    {
        const int32_t n = defsim_body_vertex_count(w_, body.id());
        if (n < 0) throw Error(static_cast<defsim_status>(n), "body is null, removed or foreign");
        return n;
    }
    /// Index of a body's first vertex in the world's arrays. Throws DEFSIM_ERR_STALE_ID.
    int32_t vertex_offset(Body body) const
    {
        const int32_t n = defsim_body_vertex_offset(w_, body.id());
        if (n < 0) throw Error(static_cast<defsim_status>(n), "body is null, removed or foreign");
        return n;
    }

    /// Total vertex count of the world (0 for an empty World).
    int32_t vertex_count() const noexcept { return defsim_world_vertex_count(w_); }
    /// Simulated time in seconds.
    double time() const noexcept { return defsim_world_time(w_); }

    /// Advances by h seconds. Throws Error (DEFSIM_ERR_UNSTABLE, DEFSIM_ERR_NOT_CONVERGED,
    /// DEFSIM_ERR_INVALID_ARGUMENT, DEFSIM_ERR_CALLBACK); the state is then exactly as before
    /// the call. When the force callback threw, its exception is rethrown instead.
    void step(double h) { check(defsim_world_step(w_, h)); }
    /// Advances by h seconds without throwing: returns the status (the state is unchanged on
    /// error; last_error() says why). An exception of the force callback is dropped.
    defsim_status try_step(double h) noexcept
    {
        const defsim_status st = defsim_world_step(w_, h);
        if (force_) force_->error = nullptr;
        return st;
    }

    // -- coupling with the host ------------------------------------------------------------

    /// Holds one external force per vertex (N, 3 * vertex_count() doubles, copied) in every
    /// step until changed; an empty span clears them. Throws DEFSIM_ERR_INVALID_ARGUMENT (size,
    /// non-finite value: the forces held before stay).
    void set_external_forces(Span<const double> f)
    {
        if (f.empty()) {
            check(defsim_world_set_external_forces(w_, nullptr, 0));
            return;
        }
        check_size(f.size(), 3, "forces");
        check(defsim_world_set_external_forces(w_, f.data(), vertex_count()));
    }
    /// Sets the force callback, with an optional Jacobian for implicit backends (without one
    /// they hold the force of the step's start over the step); an empty fn clears both. The
    /// functions live in this World. An exception thrown by either never crosses the C ABI: it
    /// is caught, the C callback reports failure, the step fails with the state unchanged, and
    /// step() (or pin_forces()) rethrows the exception.
    void set_force_callback(ForceFunction fn, ForceJacobianFunction jacobian = {})
    {
        if (!fn) {
            if (jacobian) detail::invalid("a Jacobian needs a force callback");
            check(defsim_world_set_force_callback(w_, nullptr, nullptr, nullptr));
            force_.reset();
            return;
        }
        auto state = std::make_unique<ForceState>();
        state->fn = std::move(fn);
        state->jacobian = std::move(jacobian);
        check(defsim_world_set_force_callback(
            w_, &World::force_trampoline<&ForceState::fn>,
            state->jacobian ? &World::force_trampoline<&ForceState::jacobian> : nullptr,
            state.get()));
        force_ = std::move(state);
    }
    /// Drives body-local vertices (pinned by this call if they were not) to positions (3 per
    /// vertex, m), reached at the end of the next step. Throws DEFSIM_ERR_INVALID_ARGUMENT,
    /// DEFSIM_ERR_STALE_ID; nothing changes on error.
    void set_pin_targets(Body body, Span<const int32_t> vertices, Span<const double> positions)
    {
        if (positions.size() != 3 * vertices.size())
            detail::invalid("set_pin_targets: needs 3 positions per vertex");
        check(defsim_body_set_pin_targets(w_, body.id(), vertices.data(),
                                          detail::count(vertices.size(), "vertices"),
                                          positions.data()));
    }
    /// Adds an attachment. Throws DEFSIM_ERR_INVALID_ARGUMENT, DEFSIM_ERR_STALE_ID.
    Attachment add_attachment(const AttachmentDef &def)
    {
        defsim_attachment_id id{0, 0};
        check(defsim_world_add_attachment(w_, &def.c_struct(), &id));
        return Attachment(id);
    }
    /// Removes an attachment. Throws DEFSIM_ERR_STALE_ID.
    void remove_attachment(Attachment a) { check(defsim_world_remove_attachment(w_, a.id())); }
    /// Moves an attachment's target to the world point p (m). Throws DEFSIM_ERR_STALE_ID,
    /// DEFSIM_ERR_INVALID_ARGUMENT.
    void set_attachment_target(Attachment a, const std::array<double, 3> &p)
    {
        check(defsim_attachment_set_target(w_, a.id(), p.data()));
    }
    /// The force (N) the attachment applies to its vertex now. Throws DEFSIM_ERR_STALE_ID.
    std::array<double, 3> attachment_force(Attachment a) const
    {
        std::array<double, 3> f{};
        check(defsim_world_get_attachment_force(w_, a.id(), f.data()));
        return f;
    }
    /// Adds a collider (defsim_world_add_collider). Throws DEFSIM_ERR_INVALID_ARGUMENT (bad
    /// values, an unsupported shape), DEFSIM_ERR_LOCKED, DEFSIM_ERR_OUT_OF_MEMORY.
    Collider add_collider(const ColliderDef &def)
    {
        defsim_collider_id id{0, 0};
        check(defsim_world_add_collider(w_, &def.c_struct(), &id));
        return Collider(id);
    }
    /// Removes a collider. Throws DEFSIM_ERR_STALE_ID, DEFSIM_ERR_LOCKED.
    void remove_collider(Collider c) { check(defsim_world_remove_collider(w_, c.id())); }
    /// Sets the pose (m; quaternion w, x, y, z) the collider reaches at the end of the next step.
    /// Throws DEFSIM_ERR_INVALID_ARGUMENT (non-finite, not a unit quaternion), DEFSIM_ERR_STALE_ID.
    void set_collider_pose(Collider c, const std::array<double, 3> &position,
                           const std::array<double, 4> &rotation = {1.0, 0.0, 0.0, 0.0})
    {
        check(defsim_collider_set_pose(w_, c.id(), position.data(), rotation.data()));
    }
    /// The live colliders, in order of creation.
    std::vector<Collider> colliders() const
    {
        std::vector<Collider> r;
        const int32_t n = defsim_world_collider_count(w_);
        for (int32_t i = 0; i < n; ++i) {
            defsim_collider_id id{0, 0};
            check(defsim_world_get_collider(w_, i, &id, nullptr));
            r.push_back(Collider(id));
        }
        return r;
    }
    /// The def of a live collider with its current pose. Throws DEFSIM_ERR_STALE_ID.
    defsim_collider_def collider_def(Collider c) const
    {
        const int32_t n = defsim_world_collider_count(w_);
        for (int32_t i = 0; i < n; ++i) {
            defsim_collider_id id{0, 0};
            defsim_collider_def d;
            defsim_collider_def_init(&d, sizeof d);
            check(defsim_world_get_collider(w_, i, &id, &d));
            if (Collider(id) == c) return d;
        }
        throw Error(DEFSIM_ERR_STALE_ID, "collider is removed or of another world");
    }
    /// Contact forces (N) of the last step into out (3 * vertex_count()); zero off contact.
    void contact_forces(Span<double> out) const
    {
        check_size(out.size(), 3, "contact forces");
        check(defsim_world_get_contact_forces(w_, out.data(), vertex_count()));
    }
    /// The same, as a new vector.
    std::vector<double> contact_forces() const
    {
        std::vector<double> f(3 * static_cast<std::size_t>(vertex_count()));
        contact_forces(Span<double>(f));
        return f;
    }

    /// Reaction forces of the pins (N) into out (3 * vertex_count()); zero for free vertices.
    void pin_forces(Span<double> out)
    {
        check_size(out.size(), 3, "pin forces");
        check(defsim_world_get_pin_forces(w_, out.data(), vertex_count()));
    }
    /// The same, as a new vector.
    std::vector<double> pin_forces()
    {
        std::vector<double> f(3 * static_cast<std::size_t>(vertex_count()));
        pin_forces(Span<double>(f));
        return f;
    }
    /// Per-tet Cauchy stress (9 per tet), von Mises stress and energy density of a body with
    /// tet_count tets (as added). Throws DEFSIM_ERR_INVALID_ARGUMENT (count), DEFSIM_ERR_STALE_ID.
    ElementStress element_stress(Body body, int32_t tet_count) const
    {
        if (tet_count < 0) detail::invalid("element_stress: tet_count < 0");
        const auto m = static_cast<std::size_t>(tet_count);
        ElementStress r{std::vector<double>(9 * m), std::vector<double>(m), std::vector<double>(m)};
        check(defsim_body_element_stress(w_, body.id(), r.cauchy.data(), r.von_mises.data(),
                                         r.energy_density.data(), tet_count));
        return r;
    }

    /// Copies positions (m) into out: 3 * vertex_count() doubles.
    void get_positions(Span<double> out) const
    {
        check_size(out.size(), 3, "positions");
        check(defsim_world_get_positions(w_, out.data(), vertex_count()));
    }
    /// Copies velocities (m/s) into out: 3 * vertex_count() doubles.
    void get_velocities(Span<double> out) const
    {
        check_size(out.size(), 3, "velocities");
        check(defsim_world_get_velocities(w_, out.data(), vertex_count()));
    }
    /// Copies the lumped vertex masses (kg) into out: vertex_count() doubles.
    void get_masses(Span<double> out) const
    {
        check_size(out.size(), 1, "masses");
        check(defsim_world_get_masses(w_, out.data(), vertex_count()));
    }
    /// get_positions into a new vector.
    std::vector<double> positions() const { return fetch(3, &World::get_positions); }
    /// get_velocities into a new vector.
    std::vector<double> velocities() const { return fetch(3, &World::get_velocities); }
    /// get_masses into a new vector.
    std::vector<double> masses() const { return fetch(1, &World::get_masses); }

    /// Sets positions and velocities (3 * vertex_count() each; an empty span leaves that part
    /// unchanged). Throws DEFSIM_ERR_INVALID_ARGUMENT (size, non-finite value).
    void set_state(Span<const double> x, Span<const double> v)
    {
        if (!x.empty()) check_size(x.size(), 3, "x");
        if (!v.empty()) check_size(v.size(), 3, "v");
        check(defsim_world_set_state(w_, x.empty() ? nullptr : x.data(),
                                     v.empty() ? nullptr : v.data()));
    }
    /// set_state with positions only (velocities unchanged).
    void set_positions(Span<const double> x) { set_state(x, {}); }
    /// set_state with velocities only (positions unchanged).
    void set_velocities(Span<const double> v) { set_state({}, v); }

    /// Energies of the current state (J).
    defsim_energy energy() const
    {
        defsim_energy e{};
        check(defsim_world_energy(w_, &e));
        return e;
    }
    /// Elastic forces -dE/dx (N) at the current positions into out (3 * vertex_count()).
    void forces(Span<double> out)
    {
        check_size(out.size(), 3, "forces");
        check(defsim_world_forces(w_, nullptr, out.data()));
    }
    /// Elastic forces at positions x into out (3 * vertex_count() each).
    void forces(Span<const double> x, Span<double> out)
    {
        check_size(x.size(), 3, "x");
        check_size(out.size(), 3, "forces");
        check(defsim_world_forces(w_, x.data(), out.data()));
    }
    /// The elastic forces at the current positions, as a new vector.
    std::vector<double> forces()
    {
        std::vector<double> f(3 * static_cast<std::size_t>(vertex_count()));
        forces(Span<double>(f));
        return f;
    }

    /// Counters and timings.
    defsim_stats stats() const
    {
        defsim_stats s{};
        s.size = sizeof s;
        check(defsim_world_stats(w_, &s));
        return s;
    }
    /// Zeroes the statistics (defsim_world_reset_stats).
    void reset_stats() noexcept { defsim_world_reset_stats(w_); }

    /// Sets an option by name from text (defsim_world_set_option): "core.simd" = "generic",
    /// "sundials_ida.rtol" = "1e-6", "core.auto_substep" = "true". Changing an option of the
    /// backend re-initialises it before the next step. Throws Error DEFSIM_ERR_INVALID_ARGUMENT
    /// (unknown name, another backend's option, bad value: what() lists what is valid); the
    /// world is then unchanged.
    void set_option(const std::string &name, const std::string &value)
    {
        check(defsim_world_set_option(w_, name.c_str(), value.c_str()));
    }
    /// Sets an option by name to a number (defsim_world_set_option_number): REAL and INT
    /// values, 0 or 1 for BOOL, the index of a CHOICE. Throws as set_option(name, text).
    void set_option(const std::string &name, double value)
    {
        check(defsim_world_set_option_number(w_, name.c_str(), value));
    }
    /// The current value of an option (a CHOICE gives the index of its choice). Throws Error
    /// DEFSIM_ERR_INVALID_ARGUMENT for an unknown name.
    double option(const std::string &name) const
    {
        double v = 0.0;
        check(defsim_world_get_option(w_, name.c_str(), &v));
        return v;
    }
    /// A statistic by name: a field of defsim_stats ("steps", "force_evals") or a counter of
    /// the backend ("sundials_ida.internal_steps", "newton_cholmod.newton_iterations"). Throws Error DEFSIM_ERR_INVALID_ARGUMENT
    /// for an unknown name.
    double stat(const std::string &name) const
    {
        double v = 0.0;
        check(defsim_world_stat(w_, name.c_str(), &v));
        return v;
    }

    /// Detail of the last failed call on this world ("" if none).
    std::string last_error() const { return defsim_world_last_error(w_); }

private:
    /// The force callback and the exception it threw during the current call, if any.
    struct ForceState {
        ForceFunction fn;
        ForceJacobianFunction jacobian;
        std::exception_ptr error;
    };

    void check(defsim_status st) const
    {
        if (st < 0 && !w_) throw Error(st, "the World is empty (moved from or released)");
        if (st == DEFSIM_ERR_CALLBACK && force_ && force_->error) {
            std::exception_ptr e = force_->error;
            force_->error = nullptr;
            std::rethrow_exception(e);
        }
        detail::check(st, w_);
    }
    /// The C callback of the force function (Member = &ForceState::fn) or of its Jacobian.
    template <ForceFunction ForceState::*Member>
    static int force_trampoline(void *user, const double *x, const double *v, double t,
                                int32_t n, double *out) noexcept
    {
        auto *s = static_cast<ForceState *>(user);
        try {
            (s->*Member)(x, v, t, n, out);
            return 0;
        } catch (...) {
            if (!s->error) s->error = std::current_exception();
            return 1;
        }
    }
    void check_size(std::size_t got, std::size_t per_vertex, const char *what) const
    {
        if (!w_) throw Error(DEFSIM_ERR_INVALID_ARGUMENT, "the World is empty (moved from or released)");
        if (got != per_vertex * static_cast<std::size_t>(vertex_count()))
            detail::invalid(std::string(what) + ": needs " + std::to_string(per_vertex) +
                            " values per vertex of the world");
    }
    std::vector<double> fetch(std::size_t per_vertex,
                              void (World::*get)(Span<double>) const) const
    {
        std::vector<double> r(per_vertex * static_cast<std::size_t>(vertex_count()));
        (this->*get)(Span<double>(r));
        return r;
    }
    static void log_trampoline(void *user, int level, const char *message)
    {
        try {
            (*static_cast<LogFunction *>(user))(level, message);
        } catch (...) {
            // Exceptions cannot cross the C library; a log sink's failure is dropped.
        }
    }

    defsim_world *w_ = nullptr;
    std::unique_ptr<LogFunction> log_;
    std::unique_ptr<ForceState> force_;
};

}  // namespace defsim

#endif  // DEFSIM_DEFSIM_HPP
