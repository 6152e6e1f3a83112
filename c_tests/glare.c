/*
 * Observers and glare through the C API: a luminaire of known luminance (a 0.5 m square
 * Lambertian panel from a photometric table) over a black ground under a uniform sky, an
 * observer's sensor, its vertical illuminance and UGR against CIE 117's formula worked by
 * hand; then every refusal with its status and message, the context still usable; DGP
 * of an upward fisheye picture of the sky and its refusals.
 */
#include <imap.h>

#include <math.h>
#include <stdio.h>
#include <string.h>

static int failures = 0;
static const double PI = 3.14159265358979323846;

static void check(const char *what, int ok, double got, double want) {
    if (!ok) {
        printf("FAIL %-52s got %.6g, want %.6g\n", what, got, want);
        failures++;
    } else {
        printf("ok   %-52s %.6g (%.6g)\n", what, got, want);
    }
}

static void expect(const char *what, ImapStatus status, ImapStatus want, const ImapContext *ctx,
                   const char *names) {
    const char *msg = want == IMAP_OK ? "" : imap_last_error(ctx);
    int named = names == NULL || (msg != NULL && strstr(msg, names) != NULL);
    if (status != want || !named) {
        printf("FAIL %-52s got %s, want %s (%s)\n", what, imap_status_name(status), imap_status_name(want),
               msg ? msg : "(null)");
        failures++;
    } else {
        printf("ok   %-52s %s%s%s\n", what, imap_status_name(status), want != IMAP_OK ? ": " : "",
               want != IMAP_OK ? msg : "");
    }
}

static double ground[12] = {-50, -50, 0, 50, -50, 0, 50, 50, 0, -50, 50, 0};
static uint32_t ground_idx[6] = {0, 1, 2, 0, 2, 3};

int main(void) {
    ImapConfig cfg;
    imap_config_default(&cfg, sizeof cfg);
    cfg.seed = 7;
    ImapContext *ctx = NULL;
    if (imap_create(&cfg, &ctx) != IMAP_OK) return 1;

    ImapMaterial black;
    imap_material_default(&black, sizeof black);
    double zero = 0.0;
    black.diffuse_reflectance = &zero;
    black.diffuse_reflectance_count = 1;
    uint32_t mat = 0, id = 0;
    expect("black material", imap_add_material(ctx, &black, &mat), IMAP_OK, ctx, NULL);
    ImapMesh m;
    imap_mesh_default(&m, sizeof m);
    m.positions = ground, m.vertex_count = 4, m.indices = ground_idx, m.triangle_count = 2;
    m.material = mat;
    expect("ground", imap_add_mesh(ctx, &m, &id), IMAP_OK, ctx, NULL);

    ImapSky sky;
    imap_sky_default(&sky, sizeof sky);
    sky.kind = IMAP_SKY_UNIFORM, sky.unit = IMAP_SKY_UNIT_HORIZONTAL_LX, sky.amount = 2000.0;
    expect("uniform sky of 2000 lx", imap_add_sky(ctx, &sky, NULL, &id), IMAP_OK, ctx, NULL);

    /* I(γ) = 1000 cos γ cd below the panel, a 0.5 m square opening: L = 4000 cd/m². */
    double vertical[19], candela[19], horizontal[1] = {0.0};
    for (int k = 0; k < 19; k++) {
        vertical[k] = 10.0 * k;
        candela[k] = vertical[k] <= 90.0 ? 1000.0 * cos(vertical[k] * PI / 180.0) : 0.0;
    }
    ImapPhotometry t;
    imap_photometry_default(&t, sizeof t);
    t.photometric_type = IMAP_PHOTOMETRY_C;
    t.vertical = vertical, t.vertical_count = 19, t.horizontal = horizontal, t.horizontal_count = 1;
    t.candela = candela;
    t.opening = IMAP_OPENING_RECTANGLE, t.opening_width = 0.5, t.opening_length = 0.5;
    ImapLuminaire place;
    imap_luminaire_default(&place, sizeof place);
    place.position[0] = sqrt(3.0), place.position[1] = 0.0, place.position[2] = 2.2;
    uint32_t panel = 0;
    expect("the panel", imap_add_luminaire_table(ctx, &t, &place, NULL, &panel), IMAP_OK, ctx, NULL);

    ImapObserver o;
    expect("observer defaults", imap_observer_default(&o, sizeof o), IMAP_OK, ctx, NULL);
    o.eye[2] = 1.2; /* looking along +x, up +z */
    uint32_t eye = 0;
    expect("observer sensor", imap_add_observer_sensor(ctx, &o, 0.05, &eye), IMAP_OK, ctx, NULL);

    ImapRunParams p;
    imap_run_params_default(&p, sizeof p);
    p.photons = 300000;
    ImapReport r;
    expect("run", imap_run(ctx, &p, &r, sizeof r), IMAP_OK, ctx, NULL);

    double ev[5], rel[5];
    expect("Ev", imap_get_vertex_illuminance(ctx, eye, 0, ev, 5), IMAP_OK, ctx, NULL);
    expect("Ev error", imap_get_vertex_error(ctx, eye, 0, rel, 5), IMAP_OK, ctx, NULL);
    double s = ev[0] * rel[0];
    /* The panel is seen 30° above the line of sight, 60° off its axis, 2 m away. */
    double direct = 500.0 * cos(PI / 6) / 4.0;
    check("Ev = half the sky's 2000 lx + the panel's (4 sigma)", fabs(ev[0] - (1000.0 + direct)) < 4 * s, ev[0],
          1000.0 + direct);

    ImapGlare g;
    ImapGlareSource src[4];
    size_t count = 0;
    expect("glare", imap_observer_glare(ctx, &o, ev[0], s, &g, sizeof g, src, 4, sizeof src[0], &count), IMAP_OK,
           ctx, NULL);
    check("one source, the panel", count == 1 && g.sources == 1 && src[0].kind == IMAP_GLARE_SOURCE_LIGHT &&
                                       src[0].id == panel,
          (double)count, 1);
    check("its luminance 4000 cd/m²", fabs(src[0].luminance_cd_m2 - 4000.0) < 1e-6 * 4000.0, src[0].luminance_cd_m2,
          4000.0);
    check("its solid angle 0.125/4 sr", fabs(src[0].solid_angle_sr - 0.03125) < 1e-9, src[0].solid_angle_sr,
          0.03125);
    double pidx = exp((35.2 - 1.22) * 1e-3 * 30.0 + 21e-5 * 900.0);
    check("its position index (Guth, straight above)", fabs(src[0].position_index - pidx) < 1e-9,
          src[0].position_index, pidx);
    double exact = 8.0 * log10(0.25 / (1000.0 / PI) * 4000.0 * 4000.0 * 0.03125 / (pidx * pidx));
    check("UGR by hand (4 sigma)", g.ugr_sigma > 0 && fabs(g.ugr - exact) < 4 * g.ugr_sigma + 1e-9, g.ugr, exact);
    check("an open eye is enclosed by no mesh", g.enclosed_by == IMAP_GLARE_NOT_ENCLOSED, g.enclosed_by,
          IMAP_GLARE_NOT_ENCLOSED);
    check("DGPs = 6.22e-5 Ev + 0.184", fabs(g.dgps - (6.22e-5 * ev[0] + 0.184)) < 1e-12, g.dgps,
          6.22e-5 * ev[0] + 0.184);
    /* Sources can be counted first, with no array. */
    count = 0;
    expect("count only", imap_observer_glare(ctx, &o, ev[0], s, &g, sizeof g, NULL, 0, 0, &count), IMAP_OK, ctx,
           NULL);
    check("count only: 1", count == 1, (double)count, 1);

    /* Refusals, each with its status and a message naming what is wrong. */
    ImapObserver bad = o;
    bad.view[0] = 0.0;
    expect("zero view", imap_observer_glare(ctx, &bad, 100, 1, &g, sizeof g, NULL, 0, 0, NULL),
           IMAP_ERR_INVALID_ARGUMENT, ctx, "observer.view");
    bad = o;
    bad.up[0] = 1.0, bad.up[2] = 0.0;
    expect("up along the view", imap_observer_glare(ctx, &bad, 100, 1, &g, sizeof g, NULL, 0, 0, NULL),
           IMAP_ERR_INVALID_ARGUMENT, ctx, "observer.up");
    bad = o;
    bad.eye[1] = NAN;
    expect("NaN eye", imap_observer_glare(ctx, &bad, 100, 1, &g, sizeof g, NULL, 0, 0, NULL), IMAP_ERR_NON_FINITE,
           ctx, "observer.eye");
    expect("negative Ev", imap_observer_glare(ctx, &o, -1, 1, &g, sizeof g, NULL, 0, 0, NULL),
           IMAP_ERR_INVALID_ARGUMENT, ctx, "ev_lx");
    expect("sources NULL with a capacity", imap_observer_glare(ctx, &o, 100, 1, &g, sizeof g, NULL, 2, sizeof src[0], NULL),
           IMAP_ERR_NULL_POINTER, ctx, "sources");
    expect("element size 3", imap_observer_glare(ctx, &o, 100, 1, &g, sizeof g, src, 4, 3, NULL),
           IMAP_ERR_INVALID_ARGUMENT, ctx, "element_size");
    expect("out NULL", imap_observer_glare(ctx, &o, 100, 1, NULL, sizeof g, NULL, 0, 0, NULL),
           IMAP_ERR_NULL_POINTER, ctx, "out");
    expect("observer NULL", imap_observer_glare(ctx, NULL, 100, 1, &g, sizeof g, NULL, 0, 0, NULL),
           IMAP_ERR_NULL_POINTER, ctx, "observer");
    ImapObserver unsized = o;
    unsized.struct_size = 0;
    expect("uninitialised observer", imap_observer_glare(ctx, &unsized, 100, 1, &g, sizeof g, NULL, 0, 0, NULL),
           IMAP_ERR_INVALID_ARGUMENT, ctx, "imap_observer_default");
    expect("sensor radius 0", imap_add_observer_sensor(ctx, &o, 0.0, &id), IMAP_ERR_INVALID_ARGUMENT, ctx, "radius");
    expect("glare ctx NULL", imap_observer_glare(NULL, &o, 100, 1, &g, sizeof g, NULL, 0, 0, NULL),
           IMAP_ERR_NULL_POINTER, NULL, "ctx");
    /* The eye's figures in one call; α-opic light needs wavelengths (spectral bands). */
    double ev0 = 0, s0 = 0;
    expect("observer Ev", imap_get_observer_ev(ctx, eye, &ev0, &s0), IMAP_OK, ctx, NULL);
    check("observer Ev = vertex 0", ev0 == ev[0] && s0 == s, ev0, ev[0]);
    ImapAlphaOpic ao;
    expect("alpha-opic in RGB", imap_get_observer_alpha_opic(ctx, eye, &ao, sizeof ao), IMAP_ERR_UNSUPPORTED, ctx,
           "RGB");
    expect("observer Ev of mesh 99", imap_get_observer_ev(ctx, 99, &ev0, NULL), IMAP_ERR_INDEX_OUT_OF_RANGE, ctx,
           NULL);
    /* Still usable, and nothing accumulated was lost. */
    double again[5];
    expect("Ev again", imap_get_vertex_illuminance(ctx, eye, 0, again, 5), IMAP_OK, ctx, NULL);
    check("Ev unchanged", again[0] == ev[0], again[0], ev[0]);
    expect("glare again", imap_observer_glare(ctx, &o, ev[0], s, &g, sizeof g, NULL, 0, 0, NULL), IMAP_OK, ctx, NULL);

    /* DGP from an upward angular fisheye: the whole sky (its luminance 2000/π cd/m², no
     * pixel above 2000 cd/m²: no glare source), so Ev = 2000 lx and DGP = 5.87e-5 Ev + 0.16.
     * (The panel, a luminaire, has no surface a camera sees: pictures show its light only
     * as reflected.) */
    enum { SIDE = 64 };
    ImapCamera cam;
    imap_camera_default(&cam, sizeof cam);
    cam.width = SIDE, cam.height = SIDE, cam.projection = IMAP_PROJECTION_ANGULAR_FISHEYE, cam.fov_y_deg = 180;
    cam.position[2] = 1.2, cam.direction[2] = 1, cam.up[0] = 1, cam.direction[0] = cam.direction[1] = 0;
    cam.up[1] = cam.up[2] = 0;
    ImapRenderParams rp;
    imap_render_params_default(&rp, sizeof rp);
    rp.passes = 2;
    static double picture[SIDE * SIDE * 3], picture_rel[SIDE * SIDE];
    static uint32_t labels[SIDE * SIDE];
    expect("fisheye render", imap_render(ctx, &cam, &rp, picture, SIDE * SIDE * 3, picture_rel, SIDE * SIDE, NULL, 0),
           IMAP_OK, ctx, NULL);
    ImapPictureGlare pg;
    ImapPictureSource ps[4];
    labels[0] = 99;
    expect("picture glare",
           imap_picture_glare(ctx, &cam, picture, SIDE * SIDE * 3, picture_rel, NULL, &pg, sizeof pg, ps, 4, sizeof ps[0],
                              labels, SIDE * SIDE),
           IMAP_OK, ctx, NULL);
    check("picture Ev = the sky's 2000 lx (1 %)", fabs(pg.ev_lx / 2000.0 - 1.0) < 0.01, pg.ev_lx, 2000.0);
    check("no glare source, no label", pg.sources == 0 && labels[0] == 0, pg.sources, 0);
    check("DGP = 5.87e-5 Ev + 0.16", fabs(pg.dgp - (5.87e-5 * pg.ev_lx + 0.16)) < 1e-12, pg.dgp,
          5.87e-5 * pg.ev_lx + 0.16);
    ImapGlareRules rules;
    expect("glare rules defaults", imap_glare_rules_default(&rules, sizeof rules), IMAP_OK, ctx, NULL);
    check("evalglare's threshold 2000 cd/m²", rules.threshold == 2000.0, rules.threshold, 2000.0);
    /* With a threshold of half the mean luminance, the whole sky is one source. */
    rules.threshold = 0.5;
    expect("picture glare, threshold 0.5 x mean",
           imap_picture_glare(ctx, &cam, picture, SIDE * SIDE * 3, picture_rel, &rules, &pg, sizeof pg, ps, 4,
                              sizeof ps[0], labels, SIDE * SIDE),
           IMAP_OK, ctx, NULL);
    check("the sky is one source of 2π sr", pg.sources == 1 && fabs(ps[0].solid_angle_sr / (2 * PI) - 1) < 0.02,
          ps[0].solid_angle_sr, 2 * PI);
    /* Refusals. */
    ImapCamera flat = cam;
    flat.projection = IMAP_PROJECTION_PERSPECTIVE, flat.fov_y_deg = 90;
    expect("DGP of a perspective picture",
           imap_picture_glare(ctx, &flat, picture, SIDE * SIDE * 3, NULL, NULL, &pg, sizeof pg, NULL, 0, 0, NULL, 0),
           IMAP_ERR_INVALID_ARGUMENT, ctx, "whole front hemisphere");
    flat = cam;
    flat.projection = 7;
    expect("unknown projection",
           imap_picture_glare(ctx, &flat, picture, SIDE * SIDE * 3, NULL, NULL, &pg, sizeof pg, NULL, 0, 0, NULL, 0),
           IMAP_ERR_INVALID_ARGUMENT, ctx, "camera.projection");
    expect("unknown projection (render)", imap_render(ctx, &flat, &rp, picture, SIDE * SIDE * 3, NULL, 0, NULL, 0),
           IMAP_ERR_INVALID_ARGUMENT, ctx, "camera.projection");
    flat = cam;
    flat.width = flat.height = 24;
    expect("too few pixels",
           imap_picture_glare(ctx, &flat, picture, 24 * 24 * 3, NULL, NULL, &pg, sizeof pg, NULL, 0, 0, NULL, 0),
           IMAP_ERR_INVALID_ARGUMENT, ctx, "at least 32 pixels");
    expect("radiance_count wrong",
           imap_picture_glare(ctx, &cam, picture, SIDE * SIDE, NULL, NULL, &pg, sizeof pg, NULL, 0, 0, NULL, 0),
           IMAP_ERR_INVALID_ARGUMENT, ctx, "radiance_count");
    expect("labels too small",
           imap_picture_glare(ctx, &cam, picture, SIDE * SIDE * 3, NULL, NULL, &pg, sizeof pg, NULL, 0, 0, labels, 10),
           IMAP_ERR_BUFFER_TOO_SMALL, ctx, "labels_count");
    rules.low_light = 2;
    expect("low_light 2",
           imap_picture_glare(ctx, &cam, picture, SIDE * SIDE * 3, NULL, &rules, &pg, sizeof pg, NULL, 0, 0, NULL, 0),
           IMAP_ERR_INVALID_ARGUMENT, ctx, "rules.low_light");

    imap_destroy(ctx);

    /* A spectral context: D65 skylight's α-opic EDIs are its illuminance (CIE S 026's
     * definition), the melanopic one included. */
    imap_config_default(&cfg, sizeof cfg);
    cfg.band_mode = IMAP_BANDS_SPECTRAL, cfg.band_count = 81, cfg.wavelength_min_nm = 380, cfg.wavelength_max_nm = 780;
    if (imap_create(&cfg, &ctx) != IMAP_OK) return 1;
    expect("black material (spectral)", imap_add_material(ctx, &black, &mat), IMAP_OK, ctx, NULL);
    m.material = mat;
    expect("ground (spectral)", imap_add_mesh(ctx, &m, &id), IMAP_OK, ctx, NULL);
    ImapSpectrum d65;
    imap_spectrum_default(&d65, sizeof d65);
    d65.kind = IMAP_SPECTRUM_CIE_D65;
    sky.amount = 1000.0;
    expect("D65 sky of 1000 lx", imap_add_sky(ctx, &sky, &d65, &id), IMAP_OK, ctx, NULL);
    ImapObserver up;
    imap_observer_default(&up, sizeof up);
    up.eye[2] = 1.2, up.view[0] = 0, up.view[2] = 1, up.up[0] = 1, up.up[2] = 0;
    expect("upward sensor", imap_add_observer_sensor(ctx, &up, 0.05, &eye), IMAP_OK, ctx, NULL);
    p.photons = 50000;
    expect("spectral run", imap_run(ctx, &p, &r, sizeof r), IMAP_OK, ctx, NULL);
    expect("observer Ev", imap_get_observer_ev(ctx, eye, &ev0, &s0), IMAP_OK, ctx, NULL);
    check("Ev = 1000 lx (4 sigma)", fabs(ev0 - 1000.0) < 4 * s0, ev0, 1000.0);
    expect("alpha-opic", imap_get_observer_alpha_opic(ctx, eye, &ao, sizeof ao), IMAP_OK, ctx, NULL);
    check("melanopic EDI / Ev of D65 = 1", fabs(ao.edi_lx[4] / ev0 - 1.0) < 1e-3, ao.edi_lx[4] / ev0, 1.0);
    check("melanopic DER = 1", fabs(ao.melanopic_der - 1.0) < 1e-3, ao.melanopic_der, 1.0);
    check("S-cone EDI / Ev of D65 = 1", fabs(ao.edi_lx[0] / ev0 - 1.0) < 1e-3, ao.edi_lx[0] / ev0, 1.0);
    imap_destroy(ctx);

    /* The CIE 190 UGR table of a luminaire file, without a context: the 600 mm panel
     * with I = 1000 cos γ cd (a Lambertian opening), as an IES file. */
    char ies[2048];
    int n = snprintf(ies, sizeof ies, "IESNA:LM-63-2002\nTILT=NONE\n1 -1 1 19 1 1 2 0.6 0.6 0\n1 1 40\n");
    for (int k = 0; k < 19; k++) n += snprintf(ies + n, sizeof ies - (size_t)n, "%d ", 5 * k);
    n += snprintf(ies + n, sizeof ies - (size_t)n, "\n0\n");
    for (int k = 0; k < 19; k++) n += snprintf(ies + n, sizeof ies - (size_t)n, "%.4f ", 1000.0 * cos(5.0 * k * PI / 180));
    double table[190];
    expect("UGR table of an IES file", imap_ugr_table(ies, (size_t)n, IMAP_PHOTOMETRY_FILE_IES, table, 190), IMAP_OK,
           NULL, NULL);
    /* A rotationally symmetric luminaire looks the same crosswise and endwise, and a room
     * with darker walls (the second column) has a darker background: more glare. */
    int same = 1, darker = 1, finite = 1;
    for (int r = 0; r < 19; r++) {
        for (int k = 0; k < 5; k++) {
            same &= fabs(table[10 * r + k] - table[10 * r + 5 + k]) < 1e-9;
            finite &= isfinite(table[10 * r + k]);
        }
        darker &= table[10 * r + 1] > table[10 * r];
    }
    check("UGR table: every cell rated", finite, table[0], table[0]);
    check("UGR table: crosswise = endwise for a round distribution", same, table[5], table[0]);
    check("UGR table: darker walls, more glare", darker, table[1], table[0]);
    expect("UGR table out too small", imap_ugr_table(ies, (size_t)n, IMAP_PHOTOMETRY_FILE_IES, table, 100),
           IMAP_ERR_BUFFER_TOO_SMALL, NULL, "190");
    expect("UGR table of an unknown format", imap_ugr_table(ies, (size_t)n, 7, table, 190), IMAP_ERR_INVALID_ARGUMENT,
           NULL, "format");
    char point[2048];
    memcpy(point, ies, (size_t)n + 1);
    memcpy(strstr(point, "2 0.6 0.6 0"), "2 0.0 0.0 0", 11);
    expect("UGR table of a point source", imap_ugr_table(point, (size_t)n, IMAP_PHOTOMETRY_FILE_IES, table, 190),
           IMAP_ERR_INVALID_ARGUMENT, NULL, "luminous area");
    expect("UGR table of a truncated file", imap_ugr_table(ies, 60, IMAP_PHOTOMETRY_FILE_IES, table, 190),
           IMAP_ERR_PARSE, NULL, NULL);
    printf("%s\n", failures ? "FAILED" : "all glare checks passed");
    return failures ? 1 : 0;
}
