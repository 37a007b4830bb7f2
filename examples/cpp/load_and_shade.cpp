// load_and_shade (C++17): the steps of examples/c/load_and_shade.c through the RAII wrapper
// spherebake.hpp; prints the same lines (floats with %a).
//
//   cargo build --release -p spherebake-capi
//   c++ -std=c++17 -Iinclude -Iexamples/cpp examples/cpp/load_and_shade.cpp target/release/libspherebake.a -lm -lpthread -ldl -o load_and_shade
#include <cstdio>
#include <exception>
#include <fstream>
#include <iterator>
#include <thread>
#include <vector>

#include "spherebake.hpp"

int main(int argc, char **argv) {
    if (argc != 2) {
        std::fprintf(stderr, "usage: load_and_shade FILE.sphb\n");
        return 2;
    }
    std::ifstream in(argv[1], std::ios::binary);
    if (!in) {
        std::fprintf(stderr, "load_and_shade: %s: cannot read the file\n", argv[1]);
        return 1;
    }
    std::vector<unsigned char> bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    try {
        sphb::Proxy proxy(bytes.data(), bytes.size());
        const SphbCounts &c = proxy.counts();
        const SphbViews &v = proxy.views();
        std::printf("spheres %u nodes %u samples %u bones %u\n", unsigned(c.sphere_count), unsigned(c.node_count),
                    unsigned(c.sample_count), unsigned(c.bone_count));
        std::printf("sphere0 %a %a %a %a\n", v.spheres[0].center[0], v.spheres[0].center[1], v.spheres[0].center[2],
                    v.spheres[0].radius);
        if (c.sh_order > 0) std::printf("sh order %u dc %a %a %a\n", unsigned(c.sh_order), v.sh[0], v.sh[1], v.sh[2]);
        std::vector<float> joints(16 * size_t(c.bone_count), 0.0f);
        for (uint32_t i = 0; i < c.bone_count; i++) {
            float *m = &joints[16 * size_t(i)];
            m[0] = m[5] = m[10] = m[15] = 1.0f;
            m[12] = 0.01f * float(i);
            m[13] = 0.02f;
        }
        std::vector<SphbSphere> leaves = proxy.pose(joints);
        std::printf("posed0 %a %a %a %a\n", leaves[0].center[0], leaves[0].center[1], leaves[0].center[2],
                    leaves[0].radius);
        std::vector<SphbSphere> nodes;
        float receiver[3];
        float radius;
        if (c.node_count > 0) {
            nodes = proxy.refit(leaves);
            const SphbSphere &root = nodes[c.root];
            std::printf("root %a %a %a %a\n", root.center[0], root.center[1], root.center[2], root.radius);
            receiver[0] = root.center[0];
            receiver[1] = root.center[1] - 1.5f * root.radius;
            receiver[2] = root.center[2];
            radius = 0.25f * root.radius;
            std::vector<SphbCutEntry> cut = proxy.cut(nodes, receiver, radius, SPHB_DEFAULT_THETA_MAX_RAD);
            std::printf("cut %u:", unsigned(cut.size()));
            for (const SphbCutEntry &e : cut) std::printf(" %c%u", e.is_leaf ? 'L' : 'N', unsigned(e.index));
            std::printf("\n");
        } else {
            receiver[0] = leaves[0].center[0];
            receiver[1] = leaves[0].center[1] - 1.5f * leaves[0].radius;
            receiver[2] = leaves[0].center[2];
            radius = 0.25f * leaves[0].radius;
        }
        sphb::Shadow shadow(4);
        shadow.build(proxy, leaves, c.node_count > 0 ? &nodes : nullptr, receiver, radius, SPHB_DEFAULT_THETA_MAX_RAD);
        const double up[3] = {0.0, 1.0, 0.0};
        std::vector<double> t = shadow.shading_vector(shadow.uniform_light(), up);
        for (unsigned i = 0; i < 5; i++) {
            const float n[3] = {0.0f, 1.0f, 0.0f};
            const float p[3] = {receiver[0] + radius * 0.5f * (float(i) - 2.0f), receiver[1], receiver[2]};
            std::printf("shade %u %a\n", i, shadow.shade_point(p, n, t));
        }
        if (c.sh_order > 0 && c.sample_count > 0) {
            const uint32_t order = c.sh_order < 3 ? c.sh_order : 3;
            const float up_f[3] = {0.0f, 1.0f, 0.0f};
            SphbPosed posed{proxy.get(), leaves.data(), leaves.size(), c.node_count > 0 ? nodes.data() : nullptr,
                            nodes.size(), nullptr};
            sphb::Light light(order);
            std::vector<double> env(order * order, 0.0);
            SphbError e;
            sphb::check(sphb_uniform_light(order, env.data(), env.size(), &e), e);
            SphbPass1Stats stats = light.light_spheres(posed, env);
            std::printf("pass1 samples %u blockers %u\n", unsigned(stats.samples), unsigned(stats.blocker_accumulations));
            SphbClusterSpec spec;
            sphb::check(sphb_cluster_spec_init(receiver, radius, up_f, &spec, &e), e);
            light.build(spec);
            // The built cluster is only read by the queries: receivers 0, 2, 4 on this thread, 1 and 3 on
            // another at the same time, each thread with its own scratch.
            std::array<std::array<double, 3>, 5> irr{};
            const sphb::Light &shared = light;
            auto gather = [&](unsigned first, sphb::Scratch &scratch) {
                for (unsigned i = first; i < 5; i += 2) {
                    const float p[3] = {receiver[0] + radius * 0.5f * (float(i) - 2.0f), receiver[1], receiver[2]};
                    irr[i] = shared.irradiance(p, up_f, scratch);
                }
            };
            sphb::Scratch mine, theirs;
            std::exception_ptr failed;
            std::thread other([&] {
                try {
                    gather(1, theirs);
                } catch (...) {
                    failed = std::current_exception();
                }
            });
            gather(0, mine);
            other.join();
            if (failed) std::rethrow_exception(failed);
            for (unsigned i = 0; i < 5; i++) std::printf("indirect %u %a %a %a\n", i, irr[i][0], irr[i][1], irr[i][2]);
        }
    } catch (const sphb::Error &e) {
        std::fprintf(stderr, "load_and_shade: %s: rule %u: %s\n", argv[1], unsigned(e.rule_id), e.what());
        return 1;
    }
    return 0;
}
