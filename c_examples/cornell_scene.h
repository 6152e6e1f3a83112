/*
 * The Cornell box for libimap's C examples (header-only, static functions): a 555 mm room
 * with a white floor, ceiling and back wall, a red left (x = 555) and a green right (x = 0)
 * wall as seen from the open front, two white blocks and a 130 × 105 mm lamp under the
 * ceiling emitting 17 W per band. Scene units are millimetres (ImapConfig::unit_m = 0.001). The front wall (z = 0) is optional: closed, no
 * light escapes (the illumination-map demo); open, a camera outside looks in.
 */
#ifndef CORNELL_SCENE_H
#define CORNELL_SCENE_H

#include <imap.h>

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#define CORNELL_L 555.0
#define CORNELL_LAMP_W_PER_BAND 17.0
#define CORNELL_LAMP_AREA_M2 (0.130 * 0.105)

/* A growing triangle mesh. */
typedef struct {
    double *xyz;
    uint32_t *idx;
    size_t nv, nt, cap_v, cap_t;
} Mesh;

/* The walls, blocks and lamp with their ids in the context (front unused when open). */
enum { CB_FLOOR, CB_CEILING, CB_BACK, CB_FRONT, CB_LEFT, CB_RIGHT, CB_BLOCKS, CB_LAMP, CB_PARTS };
typedef struct {
    Mesh part[CB_PARTS];
    uint32_t id[CB_PARTS];
    int closed;
} Cornell;

static void cornell_fail(ImapContext *ctx, const char *call, ImapStatus s) {
    fprintf(stderr, "%s failed: %s: %s\n", call, imap_status_name(s), imap_last_error(ctx));
    exit(1);
}

#define CHECK(call)                                          \
    do {                                                     \
        ImapStatus s_ = (call);                              \
        if (s_ != IMAP_OK) cornell_fail(ctx, #call, s_);     \
    } while (0)

static void push_vertex(Mesh *m, const double p[3]) {
    if (m->nv == m->cap_v) {
        m->cap_v = m->cap_v ? 2 * m->cap_v : 256;
        m->xyz = realloc(m->xyz, 3 * m->cap_v * sizeof(double));
        if (!m->xyz) exit(2);
    }
    memcpy(m->xyz + 3 * m->nv++, p, 3 * sizeof(double));
}

static void push_triangle(Mesh *m, uint32_t a, uint32_t b, uint32_t c) {
    if (m->nt == m->cap_t) {
        m->cap_t = m->cap_t ? 2 * m->cap_t : 256;
        m->idx = realloc(m->idx, 3 * m->cap_t * sizeof(uint32_t));
        if (!m->idx) exit(2);
    }
    uint32_t *t = m->idx + 3 * m->nt++;
    t[0] = a, t[1] = b, t[2] = c;
}

/* A quad o + s·u + t·v, s,t in [0,1], as an n×n grid; its normal is u × v. */
static void add_quad(Mesh *m, const double o[3], const double u[3], const double v[3], int n) {
    uint32_t base = (uint32_t)m->nv;
    for (int j = 0; j <= n; j++)
        for (int i = 0; i <= n; i++) {
            double s = (double)i / n, t = (double)j / n, p[3];
            for (int k = 0; k < 3; k++) p[k] = o[k] + s * u[k] + t * v[k];
            push_vertex(m, p);
        }
    for (int j = 0; j < n; j++)
        for (int i = 0; i < n; i++) {
            uint32_t a = base + j * (n + 1) + i, b = a + 1, c = a + n + 2, d = a + n + 1;
            push_triangle(m, a, b, c);
            push_triangle(m, a, c, d);
        }
}

/* An upright block on the floor: centre (cx, cz), half sizes (hx, hz), height h, rotated
 * by `angle` about the vertical axis; normals point out. */
static void add_block(Mesh *m, double cx, double cz, double hx, double hz, double h, double angle, int n) {
    double c = cos(angle), s = sin(angle);
    double ex[3] = {2 * hx * c, 0, -2 * hx * s}, ez[3] = {2 * hz * s, 0, 2 * hz * c}, ey[3] = {0, h, 0};
    double corner[3] = {cx - hx * c - hz * s, 0, cz + hx * s - hz * c};
    double top[3] = {corner[0], h, corner[2]};
    double neg_ex[3] = {-ex[0], 0, -ex[2]}, neg_ez[3] = {-ez[0], 0, -ez[2]};
    double far_x[3] = {corner[0] + ex[0], 0, corner[2] + ex[2]};
    double far_xz[3] = {far_x[0] + ez[0], 0, far_x[2] + ez[2]};
    double far_z[3] = {corner[0] + ez[0], 0, corner[2] + ez[2]};
    add_quad(m, top, ez, ex, n);         /* top, normal +y */
    add_quad(m, corner, ey, ex, n);      /* front, normal −z (before rotation) */
    add_quad(m, far_x, ey, ez, n);       /* right, +x */
    add_quad(m, far_xz, ey, neg_ex, n);  /* back, +z */
    add_quad(m, far_z, ey, neg_ez, n);   /* left, −x */
}

/* Per-band values of an RGB triple: RGB mode takes it as is; spectral bands interpolate
 * smoothly between B (450 nm), G (550 nm) and R (650 nm) over 400–700 nm. */
static void spectrum(const double rgb[3], int bands, double *out) {
    if (bands == 3) {
        memcpy(out, rgb, 3 * sizeof(double));
        return;
    }
    for (int b = 0; b < bands; b++) {
        double nm = bands == 1 ? 550 : 400 + 300.0 * b / (bands - 1);
        double v;
        if (nm <= 450) v = rgb[2];
        else if (nm <= 550) v = rgb[2] + (rgb[1] - rgb[2]) * (nm - 450) / 100;
        else if (nm <= 650) v = rgb[1] + (rgb[0] - rgb[1]) * (nm - 550) / 100;
        else v = rgb[0];
        out[b] = v;
    }
}

/* The box's context settings: RGB for 3 bands, otherwise `bands` spectral bands over
 * 400–700 nm; millimetre scene units; seed 2026. */
static void cornell_config(ImapConfig *cfg, int bands) {
    imap_config_default(cfg, sizeof *cfg);
    if (bands != 3) {
        cfg->band_mode = IMAP_BANDS_SPECTRAL;
        cfg->band_count = (uint32_t)bands;
        cfg->wavelength_min_nm = 400;
        cfg->wavelength_max_nm = 700;
    }
    cfg->unit_m = 0.001;
    cfg->seed = 2026;
}

/* Adds the box to `ctx` (`bands` bands; the walls record when `record` is set), walls
 * subdivided n × n. */
static void cornell_build(ImapContext *ctx, Cornell *box, int bands, int closed, int record, int n) {
    memset(box, 0, sizeof *box);
    box->closed = closed;
    /* Materials: the classic box's white, red and green walls, and a black lamp. */
    const double white[3] = {0.73, 0.73, 0.73}, red[3] = {0.63, 0.065, 0.05}, green[3] = {0.14, 0.45, 0.091};
    double *buf = malloc((size_t)bands * sizeof(double));
    uint32_t m_white, m_red, m_green, m_lamp;
    ImapMaterial mat;
    imap_material_default(&mat, sizeof mat);
    mat.diffuse_reflectance = buf;
    mat.diffuse_reflectance_count = (size_t)bands;
    spectrum(white, bands, buf);
    CHECK(imap_add_material(ctx, &mat, &m_white));
    spectrum(red, bands, buf);
    CHECK(imap_add_material(ctx, &mat, &m_red));
    spectrum(green, bands, buf);
    CHECK(imap_add_material(ctx, &mat, &m_green));
    imap_material_default(&mat, sizeof mat);
    CHECK(imap_add_material(ctx, &mat, &m_lamp));
    free(buf);

    /* Geometry in mm: the room [0,555]³, normals pointing in. */
    const double L = CORNELL_L;
    Mesh *p = box->part;
    add_quad(&p[CB_FLOOR], (double[3]){0, 0, 0}, (double[3]){0, 0, L}, (double[3]){L, 0, 0}, n);
    add_quad(&p[CB_CEILING], (double[3]){0, L, 0}, (double[3]){L, 0, 0}, (double[3]){0, 0, L}, n);
    add_quad(&p[CB_BACK], (double[3]){0, 0, L}, (double[3]){0, L, 0}, (double[3]){L, 0, 0}, n);
    add_quad(&p[CB_FRONT], (double[3]){0, 0, 0}, (double[3]){L, 0, 0}, (double[3]){0, L, 0}, n);
    /* Left and right as seen through the open front from z < 0: red at x = L, green at 0. */
    add_quad(&p[CB_LEFT], (double[3]){L, 0, 0}, (double[3]){0, 0, L}, (double[3]){0, L, 0}, n);
    add_quad(&p[CB_RIGHT], (double[3]){0, 0, 0}, (double[3]){0, L, 0}, (double[3]){0, 0, L}, n);
    add_block(&p[CB_BLOCKS], 185, 169, 82.5, 82.5, 165, -0.29, n / 4 > 0 ? n / 4 : 1);
    add_block(&p[CB_BLOCKS], 368, 351, 82.5, 82.5, 330, 0.29, n / 3 > 0 ? n / 3 : 1);
    /* The lamp: a 130 × 105 mm patch just under the ceiling, facing down. */
    add_quad(&p[CB_LAMP], (double[3]){213, L - 0.5, 227}, (double[3]){130, 0, 0}, (double[3]){0, 0, 105}, 1);

    for (int i = 0; i < CB_LAMP; i++) {
        if (i == CB_FRONT && !closed) continue;
        ImapMesh d;
        imap_mesh_default(&d, sizeof d);
        d.positions = p[i].xyz, d.vertex_count = p[i].nv;
        d.indices = p[i].idx, d.triangle_count = p[i].nt;
        d.material = i == CB_LEFT ? m_red : i == CB_RIGHT ? m_green : m_white;
        d.flags = record ? IMAP_MESH_RECORD : 0;
        CHECK(imap_add_mesh(ctx, &d, &box->id[i]));
    }
    /* The lamp emits 17 W per band (its exitance over 0.01365 m²); it does not record. */
    double exitance = CORNELL_LAMP_W_PER_BAND / CORNELL_LAMP_AREA_M2;
    ImapMesh d;
    imap_mesh_default(&d, sizeof d);
    d.positions = p[CB_LAMP].xyz, d.vertex_count = p[CB_LAMP].nv;
    d.indices = p[CB_LAMP].idx, d.triangle_count = p[CB_LAMP].nt;
    d.material = m_lamp, d.exitance = &exitance, d.exitance_count = 1;
    CHECK(imap_add_mesh(ctx, &d, &box->id[CB_LAMP]));
}

static void cornell_free(Cornell *box) {
    for (int i = 0; i < CB_PARTS; i++) free(box->part[i].xyz), free(box->part[i].idx);
}

#endif
