// SPDX-License-Identifier: MIT
//
// defsim-embed: how a game engine embeds defsim. The host owns the loop and the clock: each
// frame it adds the frame's duration to an accumulator, runs as many fixed physics steps as
// fit ("Fix Your Timestep"), and copies the positions into its own vertex buffer (float, as a
// GPU buffer would be), blending the last two physics states by the leftover fraction of a
// step so that motion is smooth at any frame rate. The scene is a soft beam clamped at one end
// that sags under gravity and settles, built from a box mesh.
//
//   defsim-embed [FRAMES] [BACKEND]      (defaults: 180 frames, symplectic_euler)
//
// Frame durations are simulated (60 Hz with jitter and one long hitch) rather than read from a
// wall clock, so that the output is reproducible. Exits non-zero if the simulation misbehaves.
#include <defsim/defsim.hpp>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

int main(int argc, char **argv)
{
    const int frames = argc > 1 ? std::atoi(argv[1]) : 180;
    const std::string backend = argc > 2 ? argv[2] : "symplectic_euler";
    if (frames < 1) {
        std::fprintf(stderr, "usage: defsim-embed [FRAMES] [BACKEND]\n");
        return 2;
    }
    if (!defsim::library_compatible()) {
        std::fprintf(stderr, "defsim-embed: libdefsim %d does not serve header %d\n",
                     defsim::library_version(), DEFSIM_VERSION_NUMBER);
        return 1;
    }
    try {
        // Load: the mesh, the world, the body. The mesh's arrays are copied by add_body.
        const double length = 1.0;
        defsim::Mesh mesh = defsim::Mesh::box({0, 0, 0}, {length, 0.2, 0.2}, 10, 2, 2);
        defsim::World world(defsim::WorldDef().backend(backend).gravity(0, -9.81, 0).log(
            [](int level, const char *msg) {
                if (level <= 1) std::fprintf(stderr, "defsim [%d]: %s\n", level, msg);
            }));
        const defsim::Material rubber = defsim::Material(defsim::Model::corotated)
                                            .youngs_modulus(1e6)
                                            .poisson_ratio(0.3)
                                            .density(1000)
                                            .mass_damping(2.0);
        const defsim::Body beam = world.add_body(defsim::BodyDef(mesh).material(rubber));
        std::vector<int32_t> clamp;
        int32_t tip = 0;
        const auto rest = mesh.positions();
        for (int32_t i = 0; i < mesh.vertex_count(); ++i) {
            if (rest[3 * i] == 0.0) clamp.push_back(i);
            if (rest[3 * i] == length && rest[3 * i + 1] == 0.0 && rest[3 * i + 2] == 0.0) tip = i;
        }
        world.pin(beam, clamp);

        // The renderer's buffers: an index buffer from the boundary triangles (once), and a
        // float vertex buffer refreshed every frame.
        const auto tris = mesh.triangles();
        const std::vector<uint32_t> index_buffer(tris.begin(), tris.end());
        const std::size_t n = static_cast<std::size_t>(world.vertex_count());
        std::vector<float> vertex_buffer(3 * n);
        std::vector<double> previous = world.positions(), current = previous;
        std::printf("defsim-embed: %zu vertices, %d tets, %zu triangles to draw, backend %s\n", n,
                    mesh.tet_count(), index_buffer.size() / 3, backend.c_str());

        const double dt = 1.0 / 2000.0;     // fixed physics step (s)
        const int max_steps_per_frame = 400; // beyond this, drop time rather than spiral
        double accumulator = 0.0, host_time = 0.0, lowest_tip = 0.0;
        long steps = 0;
        for (int frame = 1; frame <= frames; ++frame) {
            double frame_time = 1.0 / 60.0 + 0.004 * std::sin(0.7 * frame);
            if (frame == frames / 2) frame_time = 0.1;   // a hitch: the loader stalled
            host_time += frame_time;
            accumulator += std::min(frame_time, 0.25);

            int substeps = 0;
            while (accumulator >= dt && substeps < max_steps_per_frame) {
                std::swap(previous, current);
                const defsim_status st = world.try_step(dt);
                if (st != DEFSIM_OK) {
                    std::fprintf(stderr, "defsim-embed: step failed at t = %g: %s: %s\n",
                                 world.time(), defsim_status_string(st), world.last_error().c_str());
                    return 1;
                }
                world.get_positions(current);
                accumulator -= dt;
                ++substeps;
            }
            if (substeps == max_steps_per_frame) accumulator = 0.0;
            steps += substeps;

            // Render state: blend of the last two physics states.
            const double alpha = accumulator / dt;
            for (std::size_t i = 0; i < 3 * n; ++i)
                vertex_buffer[i] = static_cast<float>((1.0 - alpha) * previous[i] + alpha * current[i]);
            const float tip_y = vertex_buffer[3 * static_cast<std::size_t>(tip) + 1];
            if (!std::isfinite(tip_y)) {
                std::fprintf(stderr, "defsim-embed: non-finite vertex buffer\n");
                return 1;
            }
            lowest_tip = std::min(lowest_tip, static_cast<double>(tip_y));
            if (frame % 30 == 0 || frame == frames) {
                const defsim_energy e = world.energy();
                std::printf("frame %4d  host t %7.4f s  sim t %7.4f s  steps %3d  tip y %+.4f m  "
                            "E %.5g J\n",
                            frame, host_time, world.time(), substeps, tip_y, e.total);
            }
        }
        const defsim_stats s = world.stats();
        std::printf("%ld steps, %.3f s in defsim_world_step\n", steps, s.time_step);

        // The clamped end must not move, and the tip must have sagged.
        const std::vector<double> x = world.positions();
        for (int32_t i : clamp)
            for (int c = 0; c < 3; ++c)
                if (x[3 * static_cast<std::size_t>(i) + c] != rest[3 * static_cast<std::size_t>(i) + c]) {
                    std::fprintf(stderr, "defsim-embed: clamped vertex %d moved\n", i);
                    return 1;
                }
        if (!(lowest_tip < -0.01)) {
            std::fprintf(stderr, "defsim-embed: the tip did not sag (lowest y %g)\n", lowest_tip);
            return 1;
        }
        return 0;
    } catch (const defsim::Error &e) {
        std::fprintf(stderr, "defsim-embed: %s\n", e.what());
        return 1;
    }
}
