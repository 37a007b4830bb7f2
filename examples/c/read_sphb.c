/* read_sphb: reads a .sphb file without the spherebake library, from the specification alone
 * (formats/spherebake-v1.md §14): the checks of §14.1 it needs, the structs of §14.3
 * (include/spherebake_file.h, extracted from the spec), the walks of §14.4 and §14.5. Prints the
 * header, the section table and every section it knows; floats with %a (exact).
 *
 * It checks the header and table rules (1xxx, 2xxx) and every length, range and index it uses,
 * so no file makes it read out of bounds or loop; it skips the value rules it does not need
 * (finite floats, UTF-8, ...), which the library checks.
 *
 * Build (C99, no library):
 *   cc -std=c99 -Iinclude examples/c/read_sphb.c -o read_sphb
 * Usage: read_sphb FILE.sphb; on a file it rejects it prints "rule ID: what" and exits 1.
 */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "spherebake_file.h"

static const char *g_path;

static int reject(unsigned rule, const char *what) {
    fprintf(stderr, "read_sphb: %s: rule %u: %s\n", g_path, rule, what);
    return 1;
}

/* CRC-32 (IEEE 802.3, reflected 0xEDB88320, init and final XOR 0xFFFFFFFF), bitwise. */
static uint32_t crc32_of(const uint8_t *p, uint64_t n) {
    uint32_t c = 0xFFFFFFFFu;
    uint64_t i;
    int k;
    for (i = 0; i < n; i++) {
        c ^= p[i];
        for (k = 0; k < 8; k++) c = (c >> 1) ^ (0xEDB88320u & (0u - (c & 1u)));
    }
    return c ^ 0xFFFFFFFFu;
}

static int all_zero(const uint8_t *p, uint64_t from, uint64_t to) {
    for (; from < to; from++)
        if (p[from] != 0) return 0;
    return 1;
}

static uint64_t pad16(uint64_t x) { return (x + 15u) & ~(uint64_t)15u; }

/* binary16 bits to float (exact). */
static float half_to_float(uint16_t h) {
    unsigned e = (h >> 10) & 0x1Fu, m = h & 0x3FFu;
    float mag = e == 0 ? (float)m / 16777216.0f : ldexpf((float)(m | 0x400u), (int)e - 25);
    return (h & 0x8000u) ? -mag : mag;
}

/* The section of a known kind (NULL when absent) and its length. */
typedef struct {
    const uint8_t *data;
    uint64_t length;
} Section;

static double sgn(double x) { return x < 0.0 ? -1.0 : 1.0; }

static int read_samples(const Section *s, int compact, uint32_t sphere_count) {
    const SphbFileSamplesHeader *h;
    const uint32_t *off;
    uint64_t base, need;
    uint32_t i, j;
    if (s->length < 16) return reject(compact ? 5009 : 5001, "samples section shorter than its sub-header");
    h = (const SphbFileSamplesHeader *)s->data;
    base = 16 + pad16(4 * ((uint64_t)h->sphere_count + 1));
    need = base + (compact ? 24 * (uint64_t)h->sphere_count + 12 * (uint64_t)h->sample_count
                           : 32 * (uint64_t)h->sample_count);
    if (s->length != need) return reject(compact ? 5009 : 5001, "samples section length");
    if (h->sphere_count != sphere_count) return reject(5002, "samples sphere count");
    off = (const uint32_t *)(s->data + 16);
    if (off[0] != 0 || off[sphere_count] != h->sample_count) return reject(5003, "sample offsets");
    for (i = 0; i < sphere_count; i++)
        if (off[i + 1] < off[i]) return reject(5003, "sample offsets decrease");
    printf("samples %u kind %u\n", (unsigned)h->sample_count, compact ? 8u : 3u);
    for (i = 0; i < sphere_count; i++) {
        uint32_t first = off[i], count = off[i + 1] - off[i];
        printf("sphere %u first %u count %u\n", (unsigned)i, (unsigned)first, (unsigned)count);
        for (j = first; j < first + count; j++) {
            float p[3], n[3];
            unsigned dir, rule, k;
            if (!compact) {
                const SphbFileSample *r = (const SphbFileSample *)(s->data + base) + j;
                memcpy(p, r->position, sizeof p);
                memcpy(n, r->normal, sizeof n);
                dir = r->direction;
                rule = r->rule;
            } else {
                const SphbFileSampleBox *box = (const SphbFileSampleBox *)(s->data + base) + i;
                const SphbFileSampleQ16 *q = (const SphbFileSampleQ16 *)(s->data + base + 24 * (uint64_t)sphere_count) + j;
                double u, v, x, y, z, len;
                if (q->oct[0] < -32767 || q->oct[1] < -32767) return reject(5011, "octahedral normal");
                for (k = 0; k < 3; k++) p[k] = (float)((double)box->origin[k] + (double)box->step[k] * (double)q->q[k]);
                u = q->oct[0] / 32767.0;
                v = q->oct[1] / 32767.0;
                z = 1.0 - fabs(u) - fabs(v);
                if (z < 0.0) {
                    x = (1.0 - fabs(v)) * sgn(u);
                    y = (1.0 - fabs(u)) * sgn(v);
                } else {
                    x = u;
                    y = v;
                }
                len = sqrt(x * x + y * y + z * z);
                n[0] = (float)(x / len);
                n[1] = (float)(y / len);
                n[2] = (float)(z / len);
                dir = q->direction;
                rule = q->rule;
            }
            printf("sample %u %a %a %a %a %a %a %u %u\n", (unsigned)j, p[0], p[1], p[2], n[0], n[1], n[2], dir, rule);
        }
    }
    return 0;
}

/* §7.2: after the samples (rules 5012-5015); prints the count, the first four and the sum. */
static int read_areas(const Section *s, const Section *smp, const SphbFileSphere *sphere, uint32_t sphere_count) {
    const SphbFileSampleAreasHeader *h;
    const uint32_t *off = NULL;
    double sum = 0.0;
    uint32_t k, i = 0, width, count = 0;
    if (s->length < 16) return reject(5012, "sample_areas section shorter than its sub-header");
    h = (const SphbFileSampleAreasHeader *)s->data;
    if (h->encoding > 1) return reject(5015, "sample_areas encoding");
    width = h->encoding == 0 ? 4u : 2u;
    if (s->length != 16 + width * (uint64_t)h->sample_count) return reject(5012, "sample_areas section length");
    if (smp) {
        count = ((const SphbFileSamplesHeader *)smp->data)->sample_count;
        off = (const uint32_t *)(smp->data + 16);
    }
    if (!smp || h->sample_count != count) return reject(5013, "sample_areas count");
    printf("areas %u", (unsigned)h->sample_count);
    for (k = 0; k < h->sample_count; k++) {
        float a;
        int ok;
        if (h->encoding == 0) {
            memcpy(&a, s->data + 16 + 4 * (uint64_t)k, sizeof a);
            ok = isfinite(a) && a >= 0.0f;
        } else {
            uint16_t bits;
            double r;
            while (i < sphere_count && off[i + 1] <= k) i++; /* the sample's sphere */
            memcpy(&bits, s->data + 16 + 2 * (uint64_t)k, sizeof bits);
            r = i < sphere_count ? (double)sphere[i].radius : 0.0;
            a = (float)((double)half_to_float(bits) * r * r);
            ok = ((bits & 0x8000u) == 0 || bits == 0x8000u) && (bits & 0x7C00u) != 0x7C00u; /* -0 is 0 */
        }
        if (!ok) return reject(5014, "sample area");
        if (k < 4) printf(" %a", a);
        sum += a;
    }
    printf(" sum %.6f\n", sum);
    return 0;
}

static int read_hierarchy(const Section *s, uint32_t sphere_count) {
    const SphbFileHierarchyHeader *h;
    const SphbFileNode *node;
    const uint32_t *child, *leaf;
    uint32_t *stack = NULL, top = 0, visits = 0, k, j;
    unsigned char *seen = NULL;
    int status = 0;
    if (s->length < 16) return reject(4001, "hierarchy section shorter than its sub-header");
    h = (const SphbFileHierarchyHeader *)s->data;
    if (s->length != 16 + 32 * (uint64_t)h->node_count + 4 * ((uint64_t)h->child_total + h->leaf_total))
        return reject(4001, "hierarchy section length");
    if (h->node_count == 0) return reject(4002, "no nodes");
    if (h->root >= h->node_count) return reject(4003, "root index");
    node = (const SphbFileNode *)(s->data + 16);
    child = (const uint32_t *)(node + h->node_count);
    leaf = child + h->child_total;
    for (k = 0; k < h->node_count; k++) {
        if ((uint64_t)node[k].first_child + node[k].child_count > h->child_total) return reject(4006, "child range");
        if ((uint64_t)node[k].first_leaf + node[k].leaf_count > h->leaf_total) return reject(4007, "leaf range");
        for (j = 0; j < node[k].child_count; j++)
            if (child[node[k].first_child + j] >= h->node_count) return reject(4008, "child index");
        for (j = 0; j < node[k].leaf_count; j++)
            if (leaf[node[k].first_leaf + j] >= sphere_count) return reject(4009, "leaf index");
    }
    printf("nodes %u root %u children %u leaves %u\n", (unsigned)h->node_count, (unsigned)h->root,
           (unsigned)h->child_total, (unsigned)h->leaf_total);
    /* Depth-first from the root, children in array order; a node seen twice stops the walk. */
    stack = (uint32_t *)malloc(sizeof(uint32_t) * h->node_count);
    seen = (unsigned char *)calloc(h->node_count, 1);
    if (!stack || !seen) {
        status = reject(0, "out of memory");
        goto done;
    }
    stack[top++] = h->root;
    while (top > 0) {
        k = stack[--top];
        if (seen[k]) {
            status = reject(4010, "node reached twice");
            goto done;
        }
        seen[k] = 1;
        visits++;
        printf("node %u %a %a %a %a children", (unsigned)k, node[k].center[0], node[k].center[1], node[k].center[2],
               node[k].radius);
        for (j = 0; j < node[k].child_count; j++) printf(" %u", (unsigned)child[node[k].first_child + j]);
        printf(" leaves");
        for (j = 0; j < node[k].leaf_count; j++) printf(" %u", (unsigned)leaf[node[k].first_leaf + j]);
        printf("\n");
        /* Push in reverse so the first child is visited next; at most node_count pushes succeed
         * before a node repeats, and a repeat stops the walk. */
        for (j = node[k].child_count; j > 0; j--) {
            if (top == h->node_count) {
                status = reject(4010, "node reached twice");
                goto done;
            }
            stack[top++] = child[node[k].first_child + j - 1];
        }
    }
    if (visits != h->node_count) status = reject(4011, "node unreachable");
done:
    free(stack);
    free(seen);
    return status;
}

static int read_albedo(const Section *s, int half, uint32_t sphere_count) {
    const SphbFileAlbedoShHeader *h;
    uint64_t per, i;
    if (s->length < 16) return reject(half ? 6007 : 6001, "albedo section shorter than its sub-header");
    h = (const SphbFileAlbedoShHeader *)s->data;
    if (h->order < 1 || h->order > 8) return reject(6003, "SH order");
    per = (uint64_t)h->order * h->order;
    if (s->length != 16 + (half ? 6u : 12u) * (uint64_t)h->sphere_count * per)
        return reject(half ? 6007 : 6001, "albedo section length");
    if (h->sphere_count != sphere_count) return reject(6002, "albedo sphere count");
    if (h->colour_space != 0) return reject(6004, "colour space");
    if (h->basis != 0) return reject(6005, "SH basis");
    if (half)
        for (i = 0; i < 3 * per * sphere_count; i++)
            if ((((const uint16_t *)(s->data + 16))[i] & 0x7C00u) == 0x7C00u) return reject(6006, "SH coefficient");
    printf("albedo order %u kind %u sphere0", (unsigned)h->order, half ? 9u : 4u);
    for (i = 0; i < 3 * per; i++) {
        float v = half ? half_to_float(((const uint16_t *)(s->data + 16))[i]) : ((const float *)(s->data + 16))[i];
        printf(" %a", v);
    }
    printf("\n");
    return 0;
}

static int read_bones(const Section *s, uint32_t *bone_count) {
    const SphbFileBonesHeader *h;
    const SphbFileBone *b;
    const char *names;
    uint32_t i;
    if (s->length < 16) return reject(8001, "bones section shorter than its sub-header");
    h = (const SphbFileBonesHeader *)s->data;
    if (s->length != 16 + 80 * (uint64_t)h->bone_count + h->name_bytes) return reject(8001, "bones section length");
    b = (const SphbFileBone *)(s->data + 16);
    names = (const char *)(b + h->bone_count);
    printf("bones %u\n", (unsigned)h->bone_count);
    for (i = 0; i < h->bone_count; i++) {
        if ((uint64_t)b[i].name_offset + b[i].name_length > h->name_bytes) return reject(8002, "bone name range");
        if (b[i].parent != SPHB_FILE_NONE && b[i].parent >= h->bone_count) return reject(8004, "bone parent");
        printf("bone %u parent %d name %.*s m12 %a\n", (unsigned)i,
               b[i].parent == SPHB_FILE_NONE ? -1 : (int)b[i].parent, (int)b[i].name_length, names + b[i].name_offset,
               b[i].inverse_bind[12]);
    }
    *bone_count = h->bone_count;
    return 0;
}

static int read_skin(const Section *s, uint32_t sphere_count, int have_bones, uint32_t bone_count) {
    const SphbFileSkinHeader *h;
    const SphbFileSkinSlot *slot;
    uint32_t j;
    if (s->length < 16) return reject(7001, "skin section shorter than its sub-header");
    h = (const SphbFileSkinHeader *)s->data;
    if (h->bones_per_sphere < 1 || h->bones_per_sphere > 64) return reject(7003, "bones per sphere");
    if (s->length != 16 + 20 * (uint64_t)h->sphere_count * h->bones_per_sphere) return reject(7001, "skin section length");
    if (h->sphere_count != sphere_count) return reject(7002, "skin sphere count");
    if (!have_bones) return reject(7004, "skin without bones");
    slot = (const SphbFileSkinSlot *)(s->data + 16);
    printf("skin %u per sphere, sphere0", (unsigned)h->bones_per_sphere);
    for (j = 0; j < h->bones_per_sphere; j++) {
        if (slot[j].bone != SPHB_FILE_NONE && slot[j].bone >= bone_count) return reject(7005, "skin bone index");
        printf(" %d:%a", slot[j].bone == SPHB_FILE_NONE ? -1 : (int)slot[j].bone, slot[j].b);
    }
    printf("\n");
    return 0;
}

static int read_metadata(const Section *s) {
    const SphbFileMetadataHeader *h;
    const SphbFileMetadataEntry *e;
    const char *str;
    uint32_t i;
    if (s->length < 16) return reject(9001, "metadata section shorter than its sub-header");
    h = (const SphbFileMetadataHeader *)s->data;
    if (s->length != 16 + 16 * (uint64_t)h->entry_count + h->string_bytes) return reject(9001, "metadata length");
    e = (const SphbFileMetadataEntry *)(s->data + 16);
    str = (const char *)(e + h->entry_count);
    for (i = 0; i < h->entry_count; i++) {
        if ((uint64_t)e[i].key_offset + e[i].key_length > h->string_bytes ||
            (uint64_t)e[i].value_offset + e[i].value_length > h->string_bytes)
            return reject(9002, "metadata string range");
        printf("meta %.*s\n", (int)e[i].key_length, str + e[i].key_offset);
    }
    return 0;
}

static int read_file(const uint8_t *f, uint64_t len) {
    static const uint8_t magic[8] = {0x89, 'S', 'P', 'H', 'B', 0x0D, 0x0A, 0x1A};
    const SphbFileHeader *h = (const SphbFileHeader *)f;
    const SphbFileSectionEntry *t;
    Section sec[11];
    const SphbFileSpheresHeader *sh;
    const SphbFileSphere *sphere;
    uint64_t table_end, prev_end;
    uint32_t i, bone_count = 0;
    int status;

    /* §14.1 step 1: the header. */
    if (len < 64) return reject(1001, "file shorter than 64 bytes");
    if (memcmp(h->magic, magic, 8) != 0) return reject(1002, "magic");
    if (h->major != 1) return reject(1003, "major version");
    if (h->minor <= 2 ? h->header_size != 64 : (h->header_size < 64 || h->header_size % 16 != 0 || h->header_size > len))
        return reject(1004, "header size");
    if (crc32_of(f, 44) != h->header_crc32) return reject(1005, "header checksum");
    if (h->file_size != len) return reject(1006, "file size");
    if (len % 16 != 0) return reject(1007, "file size not a multiple of 16");
    /* Step 2: the table. */
    if (h->table_offset % 16 != 0 || h->table_offset < h->header_size) return reject(2001, "table offset");
    if (h->table_offset > len || (len - h->table_offset) / 32 < h->section_count) return reject(2002, "table bounds");
    table_end = h->table_offset + 32 * (uint64_t)h->section_count;
    if (crc32_of(f + h->table_offset, 32 * (uint64_t)h->section_count) != h->table_crc32)
        return reject(2003, "table checksum");
    if (!all_zero(f, h->header_size, h->table_offset)) return reject(2010, "non-zero padding");
    printf("header major %u minor %u sections %u size %llu\n", (unsigned)h->major, (unsigned)h->minor,
           (unsigned)h->section_count, (unsigned long long)h->file_size);
    /* Step 3: the entries. */
    memset(sec, 0, sizeof sec);
    t = (const SphbFileSectionEntry *)(f + h->table_offset);
    prev_end = table_end;
    for (i = 0; i < h->section_count; i++) {
        uint32_t kind = t[i].kind;
        if (t[i].offset % 16 != 0) return reject(2004, "section alignment");
        if (t[i].offset < table_end || t[i].offset > len || len - t[i].offset < t[i].length)
            return reject(2005, "section bounds");
        if (t[i].offset < prev_end) return reject(2006, "section order");
        if (kind >= 1 && kind <= 10) {
            if (sec[kind].data) return reject(2007, "duplicate section");
            if ((kind == 3 && sec[8].data) || (kind == 8 && sec[3].data) || (kind == 4 && sec[9].data) ||
                (kind == 9 && sec[4].data))
                return reject(2011, "section conflict");
        }
        if (!all_zero(f, prev_end, t[i].offset)) return reject(2010, "non-zero padding");
        if (crc32_of(f + t[i].offset, t[i].length) != t[i].crc32) return reject(2008, "section checksum");
        if (kind >= 1 && kind <= 10) {
            sec[kind].data = f + t[i].offset;
            sec[kind].length = t[i].length;
        }
        prev_end = t[i].offset + t[i].length;
        printf("section %u offset %llu length %llu\n", (unsigned)kind, (unsigned long long)t[i].offset,
               (unsigned long long)t[i].length);
    }
    if (!all_zero(f, prev_end, len)) return reject(2010, "non-zero padding");
    if (!sec[SPHB_KIND_SPHERES].data) return reject(2009, "no spheres section");
    /* Step 4: the sections, spheres first. */
    if (sec[1].length < 16) return reject(3001, "spheres section shorter than its sub-header");
    sh = (const SphbFileSpheresHeader *)sec[1].data;
    if (sec[1].length != 16 + 16 * (uint64_t)sh->sphere_count) return reject(3001, "spheres section length");
    if (sh->sphere_count == 0) return reject(3002, "no spheres");
    sphere = (const SphbFileSphere *)(sec[1].data + 16);
    printf("spheres %u\n", (unsigned)sh->sphere_count);
    for (i = 0; i < sh->sphere_count; i++) {
        if (!isfinite(sphere[i].center[0]) || !isfinite(sphere[i].center[1]) || !isfinite(sphere[i].center[2]))
            return reject(3003, "sphere centre");
        if (!isfinite(sphere[i].radius) || !(sphere[i].radius > 0.0f)) return reject(3004, "sphere radius");
        printf("sphere %u %a %a %a %a\n", (unsigned)i, sphere[i].center[0], sphere[i].center[1], sphere[i].center[2],
               sphere[i].radius);
    }
    if (sec[6].data && (status = read_bones(&sec[6], &bone_count)) != 0) return status;
    if (sec[2].data && (status = read_hierarchy(&sec[2], sh->sphere_count)) != 0) return status;
    if (sec[3].data && (status = read_samples(&sec[3], 0, sh->sphere_count)) != 0) return status;
    if (sec[8].data && (status = read_samples(&sec[8], 1, sh->sphere_count)) != 0) return status;
    if (sec[10].data) {
        const Section *smp = sec[3].data ? &sec[3] : (sec[8].data ? &sec[8] : NULL);
        if ((status = read_areas(&sec[10], smp, sphere, sh->sphere_count)) != 0) return status;
    }
    if (sec[4].data && (status = read_albedo(&sec[4], 0, sh->sphere_count)) != 0) return status;
    if (sec[9].data && (status = read_albedo(&sec[9], 1, sh->sphere_count)) != 0) return status;
    if (sec[5].data && (status = read_skin(&sec[5], sh->sphere_count, sec[6].data != NULL, bone_count)) != 0)
        return status;
    if (sec[7].data && (status = read_metadata(&sec[7])) != 0) return status;
    return 0;
}

int main(int argc, char **argv) {
    FILE *fp;
    uint8_t *bytes;
    long n;
    int status;
    if (argc != 2) {
        fprintf(stderr, "usage: read_sphb FILE.sphb\n");
        return 2;
    }
    g_path = argv[1];
    fp = fopen(argv[1], "rb");
    if (!fp || fseek(fp, 0, SEEK_END) != 0 || (n = ftell(fp)) < 0 || fseek(fp, 0, SEEK_SET) != 0) {
        if (fp) fclose(fp);
        fprintf(stderr, "read_sphb: %s: cannot read the file\n", argv[1]);
        return 1;
    }
    /* malloc memory is aligned for every record type (§14.2); +1 so an empty file is no NULL. */
    bytes = (uint8_t *)malloc((size_t)n + 1);
    if (!bytes || fread(bytes, 1, (size_t)n, fp) != (size_t)n) {
        fclose(fp);
        free(bytes);
        fprintf(stderr, "read_sphb: %s: cannot read the file\n", argv[1]);
        return 1;
    }
    fclose(fp);
    status = read_file(bytes, (uint64_t)n);
    free(bytes);
    return status;
}
