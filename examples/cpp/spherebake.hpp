// spherebake.hpp: a header-only C++17 RAII wrapper over the spherebake C ABI (spherebake.h).
// Each object owns one C handle and frees it in its destructor; copies are disabled, moves allowed.
// Failures throw sphb::Error carrying the status code, the specification's rule ID and the message.
// A `*_new` without arguments that returns NULL (only on an internal error, a caught panic) throws
// std::bad_alloc.
#ifndef SPHEREBAKE_HPP
#define SPHEREBAKE_HPP

#include <array>
#include <cstdint>
#include <stdexcept>
#include <string>
#include <utility>
#include <vector>

#include "spherebake.h"

namespace sphb {

// A failed call: code (SPHB_ERR_*), rule ID (for SPHB_ERR_INVALID_FILE) and the one-line message.
class Error : public std::runtime_error {
public:
    explicit Error(const SphbError &e) : std::runtime_error(e.message), code(e.code), rule_id(e.rule_id) {}
    int32_t code;
    uint32_t rule_id;
};

inline void check(int32_t status, const SphbError &e) {
    if (status != SPHB_OK) throw Error(e);
}

// Owns a handle T* freed by Free.
template <typename T, void (*Free)(T *)>
class Handle {
public:
    Handle() = default;
    explicit Handle(T *p) : p_(p) {}
    Handle(const Handle &) = delete;
    Handle &operator=(const Handle &) = delete;
    Handle(Handle &&o) noexcept : p_(std::exchange(o.p_, nullptr)) {}
    Handle &operator=(Handle &&o) noexcept {
        if (this != &o) {
            Free(p_);
            p_ = std::exchange(o.p_, nullptr);
        }
        return *this;
    }
    ~Handle() { Free(p_); }
    T *get() const { return p_; }

private:
    T *p_ = nullptr;
};

// A loaded proxy: the bytes are copied, the views live as long as the Proxy.
class Proxy {
public:
    Proxy(const unsigned char *bytes, size_t len) {
        SphbError e;
        SphbProxy *p = nullptr;
        check(sphb_load(bytes, len, &p, &e), e);
        h_ = Handle<SphbProxy, sphb_proxy_free>(p);
        check(sphb_proxy_counts(h_.get(), &counts_, &e), e);
        check(sphb_proxy_views(h_.get(), &views_, &e), e);
    }
    const SphbCounts &counts() const { return counts_; }
    const SphbViews &views() const { return views_; }
    const SphbProxy *get() const { return h_.get(); }

    std::vector<SphbSphere> pose(const std::vector<float> &joints) const {
        SphbError e;
        std::vector<SphbSphere> out(counts_.sphere_count);
        check(sphb_pose(get(), joints.data(), joints.size() / 16, out.data(), out.size(), &e), e);
        return out;
    }
    std::vector<SphbSphere> refit(const std::vector<SphbSphere> &leaves) const {
        SphbError e;
        std::vector<SphbSphere> out(counts_.node_count);
        check(sphb_refit(get(), leaves.data(), leaves.size(), out.data(), out.size(), &e), e);
        return out;
    }
    std::vector<SphbCutEntry> cut(const std::vector<SphbSphere> &nodes, const float center[3], float radius,
                                  float theta_max_rad) const {
        SphbError e;
        std::vector<SphbCutEntry> out(counts_.node_count + counts_.sphere_count);
        size_t len = 0;
        check(sphb_cut(get(), nodes.data(), nodes.size(), center, radius, theta_max_rad, out.data(), out.size(), &len,
                       &e),
              e);
        out.resize(len);
        return out;
    }

private:
    Handle<SphbProxy, sphb_proxy_free> h_;
    SphbCounts counts_{};
    SphbViews views_{};
};

// Shadow queries at one SH order: the context (shareable) and one receiver cluster (one thread).
class Shadow {
public:
    explicit Shadow(uint32_t order, int32_t exp_method = SPHB_EXP_PS_STAR_4) : order_(order) {
        SphbError e;
        SphbShadowContext *c = nullptr;
        check(sphb_shadow_context_new(order, exp_method, &c, &e), e);
        ctx_ = Handle<SphbShadowContext, sphb_shadow_context_free>(c);
        cluster_ = Handle<SphbShadowCluster, sphb_shadow_cluster_free>(sphb_shadow_cluster_new());
        if (!cluster_.get()) throw std::bad_alloc();
    }
    void build(const Proxy &p, const std::vector<SphbSphere> &leaves, const std::vector<SphbSphere> *nodes,
               const float center[3], float radius, float theta_max_rad) {
        SphbError e;
        check(sphb_shadow_cluster_build(cluster_.get(), p.get(), order_, leaves.data(), leaves.size(),
                                        nodes ? nodes->data() : nullptr, nodes ? nodes->size() : 0, center, radius,
                                        theta_max_rad, nullptr, &e),
              e);
    }
    std::vector<double> shading_vector(const std::vector<double> &light, const double normal[3]) const {
        SphbError e;
        std::vector<double> t(order_ * order_);
        check(sphb_shading_vector(ctx_.get(), light.data(), light.size(), normal, t.data(), t.size(), &e), e);
        return t;
    }
    std::vector<double> uniform_light() const {
        SphbError e;
        std::vector<double> l(order_ * order_);
        check(sphb_uniform_light(order_, l.data(), l.size(), &e), e);
        return l;
    }
    double shade_point(const float p[3], const float n[3], const std::vector<double> &t) const {
        SphbError e;
        double v = 0.0;
        check(sphb_shade_point(ctx_.get(), cluster_.get(), p, n, t.data(), t.size(), &v, &e), e);
        return v;
    }

private:
    uint32_t order_;
    Handle<SphbShadowContext, sphb_shadow_context_free> ctx_;
    Handle<SphbShadowCluster, sphb_shadow_cluster_free> cluster_;
};

// One-bounce indirect light of one proxy at one SH order: the context (shareable), the proxy's
// sphere lights (pass 1) and one receiver cluster (pass 2); one thread at a time per object.
// Per-thread working space of Light's const irradiance().
class Scratch {
public:
    Scratch() : s_(sphb_indirect_scratch_new()) {
        if (!s_.get()) throw std::bad_alloc();
    }
    SphbIndirectScratch *get() { return s_.get(); }

private:
    Handle<SphbIndirectScratch, sphb_indirect_scratch_free> s_;
};

class Light {
public:
    explicit Light(uint32_t order, int32_t exp_method = SPHB_EXP_PS_STAR_4) : order_(order) {
        SphbError e;
        SphbLightContext *c = nullptr;
        check(sphb_light_context_new(order, exp_method, &c, &e), e);
        ctx_ = Handle<SphbLightContext, sphb_light_context_free>(c);
        lights_ = Handle<SphbSphereLights, sphb_sphere_lights_free>(sphb_sphere_lights_new());
        cluster_ = Handle<SphbIndirectCluster, sphb_indirect_cluster_free>(sphb_indirect_cluster_new());
        if (!lights_.get() || !cluster_.get()) throw std::bad_alloc();
    }
    // Pass 1 for `posed` (kept for pass 2: its arrays must outlive the queries) under `env`
    // (order² SH radiance), with `others` blocking the sky; NULL settings are the defaults.
    SphbPass1Stats light_spheres(const SphbPosed &posed, const std::vector<double> &env,
                                 const std::vector<SphbPosed> &others = {},
                                 const SphbPass1Settings *settings = nullptr) {
        SphbError e;
        SphbPass1Stats stats{};
        posed_ = posed;
        check(sphb_light_spheres(ctx_.get(), &posed_, env.data(), env.size(), others.empty() ? nullptr : others.data(),
                                 others.size(), settings, lights_.get(), &stats, &e),
              e);
        return stats;
    }
    // Pass 2: the receiver cluster `spec` (from sphb_cluster_spec_init) lit by the proxy of pass 1.
    void build(const SphbClusterSpec &spec) {
        SphbError e;
        const SphbSphereLights *l = lights_.get();
        check(sphb_indirect_cluster_build(cluster_.get(), ctx_.get(), &posed_, &l, 1, &spec, &e), e);
    }
    // Indirect irradiance (linear RGB) at receiver p with unit normal n.
    std::array<double, 3> irradiance(const float p[3], const float n[3]) {
        SphbError e;
        std::array<double, 3> out{};
        const SphbSphereLights *l = lights_.get();
        check(sphb_indirect_irradiance(cluster_.get(), ctx_.get(), &posed_, &l, 1, p, n, out.data(), &e), e);
        return out;
    }
    // The same value from a const Light: after build(), any number of threads may call this at once, each
    // with its own Scratch.
    std::array<double, 3> irradiance(const float p[3], const float n[3], Scratch &scratch) const {
        SphbError e;
        std::array<double, 3> out{};
        const SphbSphereLights *l = lights_.get();
        check(sphb_indirect_irradiance_with(cluster_.get(), scratch.get(), ctx_.get(), &posed_, &l, 1, p, n,
                                            out.data(), &e),
              e);
        return out;
    }

private:
    uint32_t order_;
    SphbPosed posed_{};
    Handle<SphbLightContext, sphb_light_context_free> ctx_;
    Handle<SphbSphereLights, sphb_sphere_lights_free> lights_;
    Handle<SphbIndirectCluster, sphb_indirect_cluster_free> cluster_;
};

}  // namespace sphb

#endif
