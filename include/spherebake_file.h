/* The .sphb v1 file records: the C declarations of formats/spherebake-v1.md §14.3, extracted by
 * crates/spherebake-capi/tests/spec_structs.rs (do not edit; it compares). Little-endian fields. */
#ifndef SPHEREBAKE_FILE_H
#define SPHEREBAKE_FILE_H

#include <stdint.h>

/* Section kinds (§4). */
#define SPHB_KIND_SPHERES 1u
#define SPHB_KIND_HIERARCHY 2u
#define SPHB_KIND_SAMPLES 3u
#define SPHB_KIND_ALBEDO_SH 4u
#define SPHB_KIND_SKIN 5u
#define SPHB_KIND_BONES 6u
#define SPHB_KIND_METADATA 7u
#define SPHB_KIND_SAMPLES_Q16 8u
#define SPHB_KIND_ALBEDO_SH_F16 9u
#define SPHB_KIND_SAMPLE_AREAS 10u

/* Index of an unused skin slot's bone and of a root bone's parent. */
#define SPHB_FILE_NONE 0xFFFFFFFFu

/* §3, at offset 0; 64 bytes. */
typedef struct SphbFileHeader {
    uint8_t magic[8];       /* 0x89 'S' 'P' 'H' 'B' 0x0D 0x0A 0x1A */
    uint16_t major;         /* 1 */
    uint16_t minor;         /* 0; 1 with a compact section; 2 with sample_areas */
    uint32_t header_size;   /* 64 for minors 0 to 2 */
    uint32_t flags;         /* reserved, 0 */
    uint32_t section_count; /* entries in the table */
    uint64_t table_offset;  /* multiple of 16, >= header_size */
    uint64_t file_size;     /* bytes, multiple of 16 */
    uint32_t table_crc32;   /* over section_count * 32 table bytes */
    uint32_t header_crc32;  /* over header bytes 0..44 */
    uint8_t reserved[16];
} SphbFileHeader;

/* §4, section_count entries at table_offset; 32 bytes. */
typedef struct SphbFileSectionEntry {
    uint32_t kind;      /* SPHB_KIND_*, or unknown (skip) */
    uint32_t reserved;
    uint64_t offset;    /* from the start of the file, multiple of 16 */
    uint64_t length;    /* bytes, padding excluded */
    uint32_t crc32;     /* over the section's length bytes */
    uint32_t reserved2;
} SphbFileSectionEntry;

/* §5, kind 1: the sub-header, then sphere_count SphbFileSphere. */
typedef struct SphbFileSpheresHeader {
    uint32_t sphere_count; /* N >= 1 */
    uint32_t reserved[3];
} SphbFileSpheresHeader;

typedef struct SphbFileSphere {
    float center[3]; /* model space */
    float radius;    /* model units, > 0 */
} SphbFileSphere;

/* §6, kind 2: the sub-header, node_count SphbFileNode, child_total uint32_t node indices,
 * leaf_total uint32_t sphere indices. */
typedef struct SphbFileHierarchyHeader {
    uint32_t node_count;  /* M >= 1 */
    uint32_t root;        /* < M */
    uint32_t child_total; /* C */
    uint32_t leaf_total;  /* L */
} SphbFileHierarchyHeader;

typedef struct SphbFileNode {
    float center[3];
    float radius;
    uint32_t first_child; /* children: child array [first_child, first_child + child_count) */
    uint32_t child_count;
    uint32_t first_leaf;  /* leaves: leaf array [first_leaf, first_leaf + leaf_count) */
    uint32_t leaf_count;
} SphbFileNode;

/* §7 and §7.1, kinds 3 and 8: the sub-header, sphere_count + 1 uint32_t offsets, zero padding to
 * a multiple of 16, then for kind 3 sample_count SphbFileSample; for kind 8 sphere_count
 * SphbFileSampleBox and sample_count SphbFileSampleQ16. */
typedef struct SphbFileSamplesHeader {
    uint32_t sphere_count; /* N, the spheres section's */
    uint32_t sample_count; /* S */
    uint32_t reserved[2];
} SphbFileSamplesHeader;

typedef struct SphbFileSample {
    float position[3]; /* model space */
    float normal[3];   /* outward, unit */
    uint8_t direction; /* 0..91, geodesic direction (§1) */
    uint8_t rule;      /* 1, 2 or 3 */
    uint8_t reserved[6];
} SphbFileSample;

typedef struct SphbFileSampleBox {
    float origin[3]; /* position of step 0 per axis */
    float step[3];   /* model units per step, >= 0 */
} SphbFileSampleBox;

typedef struct SphbFileSampleQ16 {
    uint16_t q[3];     /* position = origin + step * q, per axis (decode in double, round to float) */
    int16_t oct[2];    /* octahedral normal, -32767..32767 (§7.1) */
    uint8_t direction;
    uint8_t rule;
} SphbFileSampleQ16;

/* §7.2, kind 10: the sub-header, then sample_count areas, one per sample of kind 3 or 8 in the
 * same order: float (model units², encoding 0) or IEEE binary16 bits as uint16_t (units of the
 * sample's sphere radius squared, encoding 1). */
typedef struct SphbFileSampleAreasHeader {
    uint32_t sample_count; /* S, the samples section's */
    uint8_t encoding;      /* 0 = float, 1 = binary16 per r² */
    uint8_t reserved[11];
} SphbFileSampleAreasHeader;

/* §8 and §8.1, kinds 4 and 9: the sub-header, then sphere_count * order * order * 3 coefficients,
 * float (kind 4) or IEEE binary16 as uint16_t (kind 9), sphere s, coefficient i, channel c at
 * index 3 * (s * order * order + i) + c. */
typedef struct SphbFileAlbedoShHeader {
    uint32_t sphere_count; /* N, the spheres section's */
    uint8_t order;         /* n in 1..8: n * n coefficients */
    uint8_t colour_space;  /* 0 = linear RGB */
    uint8_t basis;         /* 0 = real orthonormal SH, Condon-Shortley phase, i = l(l+1)+m */
    uint8_t reserved[9];
} SphbFileAlbedoShHeader;

/* §9, kind 5: the sub-header, then sphere_count * bones_per_sphere SphbFileSkinSlot. */
typedef struct SphbFileSkinHeader {
    uint32_t sphere_count;     /* N, the spheres section's */
    uint32_t bones_per_sphere; /* k in 1..64; sphere s owns slots [s * k, (s + 1) * k) */
    uint32_t reserved[2];
} SphbFileSkinHeader;

typedef struct SphbFileSkinSlot {
    uint32_t bone; /* < bone_count, or SPHB_FILE_NONE (unused; q = 0, b = 0) */
    float q[3];    /* homogeneous point, xyz part */
    float b;       /* homogeneous point, w part */
} SphbFileSkinSlot;

/* §10, kind 6: the sub-header, bone_count SphbFileBone, then name_bytes UTF-8 name bytes. */
typedef struct SphbFileBonesHeader {
    uint32_t bone_count; /* B, may be 0 */
    uint32_t name_bytes; /* T */
    uint32_t reserved[2];
} SphbFileBonesHeader;

typedef struct SphbFileBone {
    uint32_t parent;      /* < bone_count, or SPHB_FILE_NONE for a root */
    uint32_t name_offset; /* into the name bytes; not NUL-terminated */
    uint32_t name_length;
    uint32_t reserved;
    float inverse_bind[16]; /* column-major 4x4 */
} SphbFileBone;

/* §11, kind 7: the sub-header, entry_count SphbFileMetadataEntry, then string_bytes UTF-8 bytes. */
typedef struct SphbFileMetadataHeader {
    uint32_t entry_count;  /* E */
    uint32_t string_bytes; /* T */
    uint32_t reserved[2];
} SphbFileMetadataHeader;

typedef struct SphbFileMetadataEntry {
    uint32_t key_offset; /* into the string bytes; not NUL-terminated */
    uint32_t key_length; /* >= 1 */
    uint32_t value_offset;
    uint32_t value_length;
} SphbFileMetadataEntry;

#endif /* SPHEREBAKE_FILE_H */
