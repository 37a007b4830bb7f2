/* load_and_shade: loads a .sphb file with the spherebake C ABI, prints its counts, poses it with a
 * fixed joint palette, refits the hierarchy, cuts it for a receiver cluster under the model and
 * shades a few receiver points in uniform white light; when the file has samples and albedo SH it
 * also lights the proxy (pass 1) and gathers its one-bounce indirect light at the same receivers
 * (pass 2). Floats are printed with %a (exact).
 *
 * Build (C99):
 *   cargo build --release -p spherebake-capi
 *   cc -std=c99 -Iinclude examples/c/load_and_shade.c target/release/libspherebake.a -lm -lpthread -ldl -o load_and_shade
 * Usage: load_and_shade FILE.sphb
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "spherebake.h"

static int fail(const char *file, const SphbError *err) {
    fprintf(stderr, "load_and_shade: %s: rule %u: %s\n", file, (unsigned)err->rule_id, err->message);
    return 1;
}

static unsigned char *read_file(const char *path, size_t *len) {
    FILE *f = fopen(path, "rb");
    unsigned char *buf = NULL;
    long n;
    if (!f) return NULL;
    if (fseek(f, 0, SEEK_END) != 0 || (n = ftell(f)) < 0 || fseek(f, 0, SEEK_SET) != 0) {
        fclose(f);
        return NULL;
    }
    buf = (unsigned char *)malloc((size_t)n + 1);
    if (buf && fread(buf, 1, (size_t)n, f) != (size_t)n) {
        free(buf);
        buf = NULL;
    }
    fclose(f);
    *len = (size_t)n;
    return buf;
}

int main(int argc, char **argv) {
    SphbError err;
    SphbProxy *proxy = NULL;
    SphbCounts counts;
    SphbViews views;
    size_t len = 0, i, cut_len = 0;
    unsigned char *bytes;
    float *joints = NULL;
    SphbSphere *leaves = NULL, *nodes = NULL;
    SphbCutEntry *cut = NULL;
    SphbShadowContext *ctx = NULL;
    SphbShadowCluster *cluster = NULL;
    SphbLightContext *lctx = NULL;
    SphbSphereLights *lights = NULL;
    SphbIndirectCluster *icluster = NULL;
    double light[16], t[16];
    const double up[3] = {0.0, 1.0, 0.0};
    float receiver[3], receiver_radius;
    int status = 1;

    if (argc != 2) {
        fprintf(stderr, "usage: load_and_shade FILE.sphb\n");
        return 2;
    }
    bytes = read_file(argv[1], &len);
    if (!bytes) {
        fprintf(stderr, "load_and_shade: %s: cannot read the file\n", argv[1]);
        return 1;
    }
    if (sphb_load(bytes, len, &proxy, &err) != SPHB_OK) {
        free(bytes);
        return fail(argv[1], &err);
    }
    free(bytes); /* the proxy owns a copy */
    if (sphb_proxy_counts(proxy, &counts, &err) != SPHB_OK || sphb_proxy_views(proxy, &views, &err) != SPHB_OK) {
        status = fail(argv[1], &err);
        goto done;
    }
    printf("spheres %u nodes %u samples %u bones %u\n", (unsigned)counts.sphere_count, (unsigned)counts.node_count,
           (unsigned)counts.sample_count, (unsigned)counts.bone_count);
    printf("sphere0 %a %a %a %a\n", views.spheres[0].center[0], views.spheres[0].center[1],
           views.spheres[0].center[2], views.spheres[0].radius);
    if (counts.sh_order > 0) printf("sh order %u dc %a %a %a\n", (unsigned)counts.sh_order, views.sh[0], views.sh[1], views.sh[2]);

    /* The joint palette: bone j translated by (0.01 j, 0.02, 0). */
    joints = (float *)calloc(16 * (size_t)(counts.bone_count ? counts.bone_count : 1), sizeof(float));
    leaves = (SphbSphere *)calloc(counts.sphere_count, sizeof(SphbSphere));
    nodes = (SphbSphere *)calloc(counts.node_count ? counts.node_count : 1, sizeof(SphbSphere));
    if (!joints || !leaves || !nodes) goto done;
    for (i = 0; i < counts.bone_count; i++) {
        float *m = joints + 16 * i;
        m[0] = m[5] = m[10] = m[15] = 1.0f;
        m[12] = 0.01f * (float)i;
        m[13] = 0.02f;
    }
    if (sphb_pose(proxy, joints, counts.bone_count, leaves, counts.sphere_count, &err) != SPHB_OK) {
        status = fail(argv[1], &err);
        goto done;
    }
    printf("posed0 %a %a %a %a\n", leaves[0].center[0], leaves[0].center[1], leaves[0].center[2], leaves[0].radius);

    /* The receiver cluster: a ball below the root sphere (or the first sphere without hierarchy). */
    if (counts.node_count > 0) {
        if (sphb_refit(proxy, leaves, counts.sphere_count, nodes, counts.node_count, &err) != SPHB_OK) {
            status = fail(argv[1], &err);
            goto done;
        }
        printf("root %a %a %a %a\n", nodes[counts.root].center[0], nodes[counts.root].center[1],
               nodes[counts.root].center[2], nodes[counts.root].radius);
        memcpy(receiver, nodes[counts.root].center, sizeof receiver);
        receiver[1] -= 1.5f * nodes[counts.root].radius;
        receiver_radius = 0.25f * nodes[counts.root].radius;
        cut = (SphbCutEntry *)calloc(counts.node_count + counts.sphere_count, sizeof(SphbCutEntry));
        if (!cut) goto done;
        if (sphb_cut(proxy, nodes, counts.node_count, receiver, receiver_radius, SPHB_DEFAULT_THETA_MAX_RAD, cut,
                     counts.node_count + counts.sphere_count, &cut_len, &err) != SPHB_OK) {
            status = fail(argv[1], &err);
            goto done;
        }
        printf("cut %u:", (unsigned)cut_len);
        for (i = 0; i < cut_len; i++) printf(" %c%u", cut[i].is_leaf ? 'L' : 'N', (unsigned)cut[i].index);
        printf("\n");
    } else {
        memcpy(receiver, leaves[0].center, sizeof receiver);
        receiver[1] -= 1.5f * leaves[0].radius;
        receiver_radius = 0.25f * leaves[0].radius;
    }

    /* Shadows: order 4, PS*-4, uniform white light, receivers facing +y. */
    cluster = sphb_shadow_cluster_new();
    if (!cluster || sphb_shadow_context_new(4, SPHB_EXP_PS_STAR_4, &ctx, &err) != SPHB_OK ||
        sphb_shadow_cluster_build(cluster, proxy, 4, leaves, counts.sphere_count, counts.node_count ? nodes : NULL,
                                  counts.node_count, receiver, receiver_radius, SPHB_DEFAULT_THETA_MAX_RAD, NULL,
                                  &err) != SPHB_OK ||
        sphb_uniform_light(4, light, 16, &err) != SPHB_OK ||
        sphb_shading_vector(ctx, light, 16, up, t, 16, &err) != SPHB_OK) {
        status = fail(argv[1], &err);
        goto done;
    }
    for (i = 0; i < 5; i++) {
        const float n[3] = {0.0f, 1.0f, 0.0f};
        float p[3];
        double v = 0.0;
        p[0] = receiver[0] + receiver_radius * 0.5f * ((float)i - 2.0f);
        p[1] = receiver[1];
        p[2] = receiver[2];
        if (sphb_shade_point(ctx, cluster, p, n, t, 16, &v, &err) != SPHB_OK) {
            status = fail(argv[1], &err);
            goto done;
        }
        printf("shade %u %a\n", (unsigned)i, v);
    }

    /* One-bounce indirect light: pass 1 lights the samples under uniform white light and projects
     * them onto each sphere's light; pass 2 gathers those lights at the receivers. */
    if (counts.sh_order > 0 && counts.sample_count > 0) {
        const uint32_t order = counts.sh_order < 3 ? counts.sh_order : 3;
        const float upf[3] = {0.0f, 1.0f, 0.0f};
        const SphbSphereLights *source_lights;
        SphbPosed posed;
        SphbPass1Stats stats;
        SphbClusterSpec spec;
        posed.proxy = proxy;
        posed.leaves = leaves;
        posed.leaf_count = counts.sphere_count;
        posed.nodes = counts.node_count ? nodes : NULL;
        posed.node_count = counts.node_count;
        posed.rotations = NULL; /* rigid pose: identity rotations */
        lights = sphb_sphere_lights_new();
        icluster = sphb_indirect_cluster_new();
        if (!lights || !icluster || sphb_light_context_new(order, SPHB_EXP_PS_STAR_4, &lctx, &err) != SPHB_OK ||
            sphb_uniform_light(order, light, 16, &err) != SPHB_OK ||
            sphb_light_spheres(lctx, &posed, light, order * order, NULL, 0, NULL, lights, &stats, &err) != SPHB_OK ||
            sphb_cluster_spec_init(receiver, receiver_radius, upf, &spec, &err) != SPHB_OK) {
            status = fail(argv[1], &err);
            goto done;
        }
        printf("pass1 samples %u blockers %u\n", (unsigned)stats.samples, (unsigned)stats.blocker_accumulations);
        source_lights = lights;
        if (sphb_indirect_cluster_build(icluster, lctx, &posed, &source_lights, 1, &spec, &err) != SPHB_OK) {
            status = fail(argv[1], &err);
            goto done;
        }
        for (i = 0; i < 5; i++) {
            float p[3];
            double e[3];
            p[0] = receiver[0] + receiver_radius * 0.5f * ((float)i - 2.0f);
            p[1] = receiver[1];
            p[2] = receiver[2];
            if (sphb_indirect_irradiance(icluster, lctx, &posed, &source_lights, 1, p, upf, e, &err) != SPHB_OK) {
                status = fail(argv[1], &err);
                goto done;
            }
            printf("indirect %u %a %a %a\n", (unsigned)i, e[0], e[1], e[2]);
        }
    }
    status = 0;
done:
    sphb_indirect_cluster_free(icluster);
    sphb_sphere_lights_free(lights);
    sphb_light_context_free(lctx);
    sphb_shadow_cluster_free(cluster);
    sphb_shadow_context_free(ctx);
    free(cut);
    free(nodes);
    free(leaves);
    free(joints);
    sphb_proxy_free(proxy);
    return status;
}
